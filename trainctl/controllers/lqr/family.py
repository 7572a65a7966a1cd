# The LQR family as a registry entry: the unconstrained baseline every comparison needs.
"""The LQR family object (:data:`FAMILY`), see :mod:`trainctl.registry`.

Two strategies on the run's discrete design model (inputs in kN):

``"centralised"``
    One gain on the whole train: ``control.dlqr(A, B, Q, R)`` with
    Q = Cᵀ diag(q) C on the controlled outputs (speeds [m/s], coupler forces
    [kN]) and R = r·I [per kN²].
``"decentralised"``
    One gain per coach from its own subsystem (A_ii, B_i of seed 000's
    decomposition, the neighbours ignored), discretised at the sample time,
    with the weights of the outputs the coach owns (its speed and the coupler
    behind it); the global gain is block diagonal in the coaches' states.

Both run with the cruise feedforward and the envelope as saturation
(:class:`~trainctl.controllers.lqr.controller.LQRController`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.family import FamilyBase

if TYPE_CHECKING:
    import control as ct

    from trainctl.analysis.check import Check
    from trainctl.controllers.hooks import StrategyRun
    from trainctl.controllers.lqr.controller import LQRController
    from trainctl.controllers.lqr.settings import LQRSettings
    from trainctl.design import DesignModel
    from trainctl.scenario import Scenario

__all__ = ["CHECK_NAMES", "FAMILY", "STRATEGIES", "LQRDesign", "LQRFamily", "design_lqr"]

DARE_METHOD = "scipy"
"""The Riccati solver python-control's ``dlqr`` uses. With slycot installed it would take
SLICOT's sg02ad, which refuses (info 4, "poor scaling") the discrete Riccati equation of a
24-car crh2-potential train that scipy's solver solves (measured); the gain is checked by
the closed-loop checks either way."""

STRATEGIES = ("centralised", "decentralised")
"""The LQR strategies: one gain on the whole train, or one per coach."""

CHECK_NAMES = ("lqr_closed_loop", "lqr_decentralised_closed_loop")
"""The LQR family's design checks."""

Array = NDArray[np.float64]

PARTIAL = """\
<p>Discrete LQR on the design model (inputs in kN), Q = CᵀWC on the outputs
{{ data.outputs | join(", ") }}, R = {{ data.r_text }} {{ data.unit }}; the cruise feedforward
is added and the inputs are saturated to the envelope{% if not data.input_bounds %} (off in this
scenario){% endif %}.</p>
<table class="quantities">
  <thead><tr><th scope="col">Strategy</th><th scope="col">Closed-loop spectral radius [-]</th>
  <th scope="col">Largest gain [kN per unit state]</th></tr></thead>
  <tbody>
{% for row in data.rows %}
    <tr><td>{{ row.strategy }}</td><td class="num">{{ row.radius }}</td>
    <td class="num">{{ row.gain }}</td></tr>
{% endfor %}
  </tbody>
</table>
"""


@dataclass(frozen=True, kw_only=True, eq=False)
class LQRDesign:
    """The LQR family's design of one scenario.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    model : DesignModel
        The run's design model.
    settings : LQRSettings
        Outputs, weights and saturation.
    A, B : ndarray
        Discrete design model (inputs in kN).
    Q, R : ndarray
        State and input weights of the centralised design.
    gains : mapping of str to ndarray
        K per strategy, shape (n, 2n-1) [kN per unit state].

    Examples
    --------
    Weighting the four speeds only (q_velocity = 1 per (m/s)²) puts ones on
    the speed entries of Q and zeros on the three couplers; R = 0.1 I per kN²:

    >>> from trainctl.controllers.lqr.settings import LQRSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc-well-sampled")
    >>> design = FAMILY.design(scenario, build_model(scenario), LQRSettings(input_weight=0.1))
    >>> np.diag(design.Q).tolist(), np.diag(design.R).tolist()
    ([1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], [0.1, 0.1, 0.1, 0.1])
    >>> K = design.gains["decentralised"]  # coach i sees v_i and the coupler behind it
    >>> (np.abs(K) > 0).astype(int).tolist()  # doctest: +NORMALIZE_WHITESPACE
    [[1, 0, 0, 0, 1, 0, 0], [0, 1, 0, 0, 0, 1, 0],
     [0, 0, 1, 0, 0, 0, 1], [0, 0, 0, 1, 0, 0, 0]]
    """

    scenario: Scenario
    model: DesignModel
    settings: LQRSettings
    A: Array
    B: Array
    Q: Array
    R: Array
    gains: Mapping[str, Array]

    def closed_loop_matrix(self, strategy: str) -> Array:
        """A - B K of a strategy.

        Parameters
        ----------
        strategy : str
            ``"centralised"`` or ``"decentralised"``.

        Returns
        -------
        ndarray, shape (2n-1, 2n-1)
            The discrete closed-loop state matrix on the design state
            (speeds [m/s], elongations [m]).
        """
        return np.asarray(self.A - self.B @ self.gains[strategy], dtype=float)


def design_lqr(scenario: Scenario, model: DesignModel, settings: LQRSettings) -> LQRDesign:
    """Centralised and decentralised discrete LQR gains.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    model : DesignModel
        Its design model.
    settings : LQRSettings
        ``outputs``, ``q_velocity`` [per (m/s)²], ``q_force`` [per kN²],
        ``input_weight_per_kn2()``, ``input_bounds``.

    Returns
    -------
    LQRDesign
        Gains of both strategies.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc-well-sampled")
    >>> settings = SimpleNamespace(outputs=("v",), q_velocity=1.0, q_force=0.0,
    ...                            input_weight_per_kn2=lambda: 0.1, input_bounds=True)
    >>> design = design_lqr(scenario, build_model(scenario), settings)
    >>> design.gains["centralised"].shape, design.gains["decentralised"].shape
    ((4, 7), (4, 7))
    """
    import control as ct

    sysd = model.select(model.discrete, tuple(settings.outputs))
    A, B, C = (np.asarray(m, dtype=float) for m in (sysd.A, sysd.B, sysd.C))
    q = _output_weights(model, settings)
    Q = C.T @ (q[:, None] * C)
    R = np.eye(B.shape[1]) * settings.input_weight_per_kn2()
    K, _, _ = ct.dlqr(A, B, Q, R, method=DARE_METHOD)
    gains = {"centralised": np.asarray(K, dtype=float),
             "decentralised": _decentralised_gain(model, settings, C, q)}
    return LQRDesign(scenario=scenario, model=model, settings=settings, A=A, B=B, Q=Q, R=R,
                     gains=gains)


def _output_weights(model: DesignModel, settings: LQRSettings) -> Array:
    n, nc = model.n_vehicles, model.train.n_couplers
    weight = {"v": np.full(n, settings.q_velocity), "force": np.full(nc, settings.q_force)}
    return np.concatenate([weight[g] for g in settings.outputs])


def _decentralised_gain(model: DesignModel, settings: LQRSettings, C: Array,
                        q: Array) -> Array:
    """Block-diagonal K from each coach's own (A_ii, B_i) and the outputs it owns."""
    import control as ct

    from trainctl.models.discrete import discretise

    n, nc, nx = model.n_vehicles, model.train.n_couplers, model.n_states
    sub, cfg = model.subsystems, model.settings
    owner = np.concatenate([np.arange(n) if g == "v" else np.arange(nc)
                            for g in settings.outputs])
    K = np.zeros((n, nx))
    for i in range(n):
        states = [i] + ([n + i] if i < nc else [])  # v_i and the coupler behind coach i
        k = len(states)
        local = ct.ss(sub.A[i, i][:k, :k], sub.B[i][:k] * 1e3, np.eye(k), 0)
        sysd = discretise(local, cfg.sample_time, method=cfg.discretisation)
        rows = owner == i
        Ci = C[np.ix_(rows, states)]
        Qi = Ci.T @ (q[rows, None] * Ci)
        Ri = np.eye(1) * settings.input_weight_per_kn2()
        Ki, _, _ = ct.dlqr(np.asarray(sysd.A), np.asarray(sysd.B), Qi, Ri, method=DARE_METHOD)
        K[i, states] = np.asarray(Ki, dtype=float)[0]
    return K


class LQRFamily(FamilyBase[LQRDesign, "LQRSettings"]):
    """Discrete LQR of the train: centralised and decentralised (per coach).

    Examples
    --------
    >>> from trainctl.controllers.lqr.settings import LQRSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc-well-sampled")
    >>> design = FAMILY.design(scenario, build_model(scenario), LQRSettings(input_weight=0.1))
    >>> [(c.name, c.status) for c in FAMILY.checks(design)]
    [('lqr_closed_loop', 'pass'), ('lqr_decentralised_closed_loop', 'pass')]
    >>> ctl = FAMILY.make(design, "centralised")
    >>> ctl.name, ctl.dt  # the model's sample time [s]
    ('centralised', 0.05)
    """

    name = "lqr"
    title = "Linear-quadratic regulator"
    strategies = STRATEGIES
    check_names = CHECK_NAMES
    report_partial = PARTIAL
    settings_path = "trainctl.controllers.lqr.settings:LQRSettings"
    _design = staticmethod(design_lqr)

    def make(self, design: LQRDesign, strategy: str) -> LQRController:
        """The controller of one strategy: feedforward, gain, saturation.

        Parameters
        ----------
        design : LQRDesign
            The family's design.
        strategy : str
            ``"centralised"`` or ``"decentralised"``.

        Returns
        -------
        LQRController
            With the strategy's gain, the model's sample time [s] and the
            settings' ``input_bounds``, named after the strategy.
        """
        from trainctl.controllers.lqr.controller import LQRController

        return LQRController(design.scenario.train, design.gains[strategy],
                             dt=design.model.settings.sample_time,
                             input_bounds=design.settings.input_bounds, name=strategy)

    def checks(self, design: LQRDesign) -> list[Check]:
        """Spectral radius of each strategy's closed loop on the coupled model.

        Parameters
        ----------
        design : LQRDesign
            The family's design.

        Returns
        -------
        list of Check
            ``lqr_closed_loop`` (centralised) and ``lqr_decentralised_closed_loop``.
        """
        from trainctl.analysis.check import radius_check

        labels = design.scenario.train.state_labels()
        hint = "raise the output weights or lower R"
        return [radius_check(name, design.closed_loop_matrix(strategy), labels,
                             f"{strategy} LQR", marginal_hint=hint,
                             unstable_hint=("the coaches' own gains destabilise the coupled "
                                            "train: weight the coupler forces or use the "
                                            "centralised gain" if strategy == "decentralised"
                                            else hint))
                for name, strategy in zip(CHECK_NAMES, STRATEGIES, strict=True)]

    def closed_loop(self, design: LQRDesign, strategy: str) -> ct.StateSpace:
        """x⁺ = (A - BK) x + B_w w; outputs ``v[i]`` [m/s], ``f[i]`` [kN], ``d[i]`` [m].

        Speed deviations, coupler-force deviations and spacing deviations
        (:meth:`~trainctl.design.DesignModel.loop_outputs`).

        Parameters
        ----------
        design : LQRDesign
            The family's design.
        strategy : str
            ``"centralised"`` or ``"decentralised"``.

        Returns
        -------
        control.StateSpace
            Discrete, ``dt`` the sample time [s]; inputs the disturbances
            ``w[i]`` of the design model's disturbance matrix.
        """
        import control as ct

        model = design.model
        n = model.n_vehicles
        C, outputs = model.loop_outputs()
        return ct.ss(design.closed_loop_matrix(strategy), model.disturbance_matrix(), C, 0,
                     dt=model.settings.sample_time, states=design.scenario.train.state_labels(),
                     inputs=[f"w[{i}]" for i in range(n)], outputs=outputs,
                     name=f"lqr_{strategy}")

    def report_data(self, design: LQRDesign) -> dict[str, Any]:
        """Closed-loop spectra and gain sizes, JSON-safe.

        Parameters
        ----------
        design : LQRDesign
            The family's design.

        Returns
        -------
        dict of str to object
            ``spectra`` (closed-loop eigenvalues as [re, im] pairs per
            strategy), ``rows`` (spectral radius [-] and largest gain [kN per
            unit state] per strategy, as text), ``outputs``, ``r_text``,
            ``unit`` and ``input_bounds``.
        """
        spectra, rows = {}, []
        for strategy in STRATEGIES:
            lam = np.linalg.eigvals(design.closed_loop_matrix(strategy)).astype(complex)
            order = np.lexsort((np.round(np.abs(lam), 12), np.round(np.angle(lam), 12)))
            spectra[f"LQR {strategy}"] = [[float(z.real), float(z.imag)] for z in lam[order]]
            rows.append({"strategy": strategy, "radius": f"{float(np.max(np.abs(lam))):.6g}",
                         "gain": f"{float(np.max(np.abs(design.gains[strategy]))):.4g}"})
        settings = design.settings
        return {"spectra": spectra, "rows": rows, "outputs": list(settings.outputs),
                "r_text": f"{settings.input_weight_per_kn2():.4g}", "unit": "per kN²",
                "input_bounds": bool(settings.input_bounds)}

    # -- optional hooks (trainctl.controllers.hooks.FamilyHooks) ------------------------------

    settings_labels = MappingProxyType({
        "q_velocity": "Velocity weight Q_v", "q_force": "Coupler-force weight Q_f",
        "input_weight": "Input weight R"})

    def strategy_seconds(self, run: StrategyRun) -> float:
        """A state feedback's simulation: the plant and the step overhead per sample, no build.

        Parameters
        ----------
        run : StrategyRun
            The strategy's simulation as the budget sees it.

        Returns
        -------
        float
            ``samples · (plant + STEP_SECONDS)`` [s].
        """
        from trainctl.controllers.hooks import STEP_SECONDS

        return run.samples * (run.plant_seconds + STEP_SECONDS)


FAMILY = LQRFamily()
"""The registry entry of the LQR family."""
