# The compiled inner loop of a static linear law on the one-substep plant map (numba).
"""The closed loop of a :class:`~trainctl.controllers.base.LinearLaw` in one compiled
function (private; imported only when numba is installed: ``pip install trainctl-toolbox[fast]``).

Why compiled: the loop's NumPy floor for the 4-coach LQR run is 17 µs a sample,
nearly all of it the dispatch of some forty ufunc calls on four-entry arrays
(``benchmarks/loop_cost.py --floor``); the same operations compiled take under
1 µs. Every operation is the one the Python path does, in its order, on the
same operands (the law of :class:`~trainctl.controllers.lqr.LQRController`,
:meth:`EnvelopeBounds.clip <trainctl.models.envelope.EnvelopeBounds.clip>`,
:meth:`ActuatorLimits.apply <trainctl.models.actuator.ActuatorLimits.apply>`,
:meth:`SampleMap.advance <trainctl.models._plant_sample.SampleMap.advance>`),
so the records are the Python path's bit for bit (``tests/test_lane.py``).
The kernel stops at the first sample it does not handle and says why
(:data:`DONE`, :data:`PYTHON`, :data:`GRID`, :data:`DIVERGED`); the loop does that sample
its own way and calls again.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

DONE, PYTHON, GRID, DIVERGED = 0, 1, 2, 3
"""The kernel's stop codes: the chunk is done; sample k is the Python path's (a state,
feedback or plant step that is not finite); sample k needs the grid speed's map; sample
k is done and its speed error exceeds the divergence bound."""


@numba.njit(cache=True, nogil=True)
def run_chunk(k0: Any, k1: Any, states: Any, dense: Any, requested: Any, applied: Any,
              saturation: Any, dense_ref: Any, vref: Any, ff: Any, eff: Any, gain: Any,
              scale: Any, limits: Any, clip_on: Any, actuate_on: Any, tol: Any, davis0: Any,
              grade: Any, quadratic: Any, half: Any, spacing: Any, steps: Any, flows: Any,
              drags: Any, have: Any, g0: Any, per: Any, bound: Any) -> Any:
    """Samples k0 <= k < k1 (rows k - k0 of vref, ff, eff); returns (k, code)."""
    n = requested.shape[0]
    m = 2 * n - 1
    dev = np.empty(m)
    z = np.empty(3 * n - 1)
    u = np.empty(n)
    low = np.empty((2, n))
    high = np.empty((2, n))
    for k in range(k0, k1):
        r = k - k0
        x = states[:, k]
        for i in range(2 * n):
            if not np.isfinite(x[i]):
                return k, PYTHON
        speed = vref[r]
        for i in range(n):
            dev[i] = x[i] - speed
        for i in range(n - 1):
            dev[n + i] = x[n + i] - eff[r, i]
        product = gain @ dev
        for i in range(n):
            feedback = scale * product[i]
            if not np.isfinite(feedback):
                return k, PYTHON
            u[i] = ff[r, i] - feedback
        for i in range(n):  # both envelopes at the measured speeds (EnvelopeBounds.at)
            v = max(abs(x[i]), 0.1)
            for e in range(2):  # limits[e]: (force, power, cap) x (braking, traction)
                low[e, i] = -min(min(limits[e, 0, 0, i], limits[e, 1, 0, i] / v),
                                 limits[e, 2, 0, i])
                high[e, i] = min(min(limits[e, 0, 1, i], limits[e, 1, 1, i] / v),
                                 limits[e, 2, 1, i])
        vbar = 0.0
        g = 0
        if quadratic:
            g = int(np.rint(x[0] / spacing))  # grid_speed: round half to even
            vbar = spacing * g
        if g - g0 < 0 or g - g0 >= have.shape[0] or not have[g - g0]:
            return k, GRID
        for i in range(n):
            if clip_on:  # the controller's clip
                u[i] = min(max(u[i], low[0, i]), high[0, i])
            requested[i, k] = u[i]
            a = u[i]
            side = 0
            if actuate_on:  # the actuators
                lo, hi = low[1, i], high[1, i]
                over = a > hi + tol
                under = a < lo - tol
                if over:
                    a = hi
                if under:
                    a = lo
                if over or (hi > tol and a >= hi - tol):
                    side = 1
                if under or (lo < -tol and a <= lo + tol):
                    side = -1
            applied[i, k] = a
            saturation[i, k] = side
            base = a - davis0[i]
            if grade.shape[0]:
                base = base - grade[i]
            z[m + i] = base
        for i in range(m):
            z[i] = x[i]
        s = x[m]
        j = g - g0
        if quadratic:
            for i in range(n):
                z[m + i] = z[m + i] + drags[j, i]
            for i in range(n):
                w = z[i] - vbar
                d = half[i] * w
                d += 1.0
                z[i] = w / d + vbar
        column = k * per + 1
        if per > 1:
            points = flows[j] @ z
            for c in range(per - 1):
                for i in range(m):
                    dense[i, column + c] = points[c * 2 * n + i]
                dense[m, column + c] = s + points[c * 2 * n + m]
        new = steps[j] @ z
        s += new[m]
        for i in range(m):
            z[i] = new[i]
        if quadratic:
            for i in range(n):
                w = z[i] - vbar
                d = half[i] * w
                d += 1.0
                z[i] = w / d + vbar
        end = k + 1
        for i in range(m):
            states[i, end] = z[i]
        states[m, end] = s
        if per > 1:
            for i in range(2 * n):
                dense[i, column + per - 1] = states[i, end]
        for c in range(column, column + per):
            for i in range(2 * n):
                if not np.isfinite(dense[i, c]):
                    return k, PYTHON
        if bound < np.inf:
            for c in range(column, column + per):
                for i in range(n):
                    if abs(dense[i, c] - dense_ref[c]) > bound:
                        return k, DIVERGED
    return k1, DONE
