# The linear models of one scenario, built once per run.
"""The design model: one linearisation and one discretisation per run.

:func:`build_model` linearises the scenario's train once (both output groups,
the dummy state as the scenario asks) and derives from it everything the
review, the controllers and the report need, without linearising or
discretising again:

- ``linear``: the continuous model in SI (inputs ``u[i]`` [N]; outputs the
  speeds ``v[i]`` [m/s] and coupler forces ``f[i]`` [N]; seed 000's dummy
  state when ``[model] dummy_state``);
- ``design``: the continuous *design* model without the dummy state, inputs
  in kN and outputs the groups the controller asks for (speeds [m/s],
  coupler forces [kN]), so that weights are plain numbers;
- ``discrete``: ``design`` sampled at the scenario's sample time (a discrete
  ``control.StateSpace`` with named signals and ``dt``);
- the per-coach subsystems (A_ii, A_ij, B_i, C_i) and the cruise equilibrium.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import control as ct
import numpy as np
from numpy.typing import NDArray

from trainctl._validation import check_finite_arrays
from trainctl.exceptions import ModelError
from trainctl.models.discrete import discretise
from trainctl.models.dynamics import Equilibrium, equilibrium
from trainctl.models.linear import linearise
from trainctl.models.subsystems import CoachSubsystems, coach_subsystems

if TYPE_CHECKING:
    from trainctl.models.train import Train
    from trainctl.scenario import ModelSettings, Scenario

__all__ = ["KN", "DesignModel", "build_model"]

KN = 1e3
"""Newtons per kilonewton: design inputs and coupler-force outputs are in kN."""

Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True, eq=False)
class DesignModel:
    """The linear models of one scenario (module docstring).

    Parameters
    ----------
    train : Train
        The train.
    settings : ModelSettings
        Linearisation speed [m/s], sample time [s] and methods.
    outputs : tuple of str
        Output groups of ``design`` and ``discrete``: ``"v"`` speeds [m/s],
        ``"force"`` coupler forces [kN].
    linear : control.StateSpace
        Continuous SI model: states ``[v, delta]`` (+ ``delta[n-1]``, the
        dummy, when ``settings.dummy_state``), inputs [N], outputs speeds
        [m/s] then coupler forces [N].
    design : control.StateSpace
        Continuous design model: no dummy state, inputs [kN], outputs the
        speeds [m/s] then the coupler forces [kN] (all groups; see
        :meth:`select` for the groups a controller uses).
    discrete : control.StateSpace
        ``design`` discretised at ``settings.sample_time`` with
        ``settings.discretisation``.
    subsystems : CoachSubsystems
        Per-coach blocks (with the dummy state as ``settings`` asks).
    equilibrium : Equilibrium
        Cruise equilibrium at ``settings.speed`` on the scenario's track.

    Examples
    --------
    The CRH2 half train (4 vehicles, 3 couplers) with the dummy state:

    >>> from trainctl.scenario import load_scenario
    >>> m = build_model(load_scenario("crh2-dmpc"))
    >>> m.linear.nstates, m.design.nstates, m.n_vehicles  # the design model drops the dummy
    (8, 7, 4)
    >>> # Inputs in kN: 1 kN on the 42.8 t head vehicle gives 1000/42800 = 0.02336 m/s².
    >>> round(float(m.design.B[0, 0]), 5)
    0.02336
    >>> m.select(m.design, ("force",)).output_labels  # coupler forces only [kN]
    ['f[0]', 'f[1]', 'f[2]']
    >>> m.discrete.dt  # [s]
    20.0
    """

    train: Train
    settings: ModelSettings
    outputs: tuple[str, ...]
    linear: ct.StateSpace
    design: ct.StateSpace
    discrete: ct.StateSpace
    subsystems: CoachSubsystems
    equilibrium: Equilibrium

    def __getstate__(self) -> dict[str, Any]:
        # control.StateSpace holds a lambda and does not pickle: keep its data instead, so a
        # design can be sent to worker processes.
        state = dict(self.__dict__)
        for key in _SYSTEMS:
            state[key] = _system_data(state[key])
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        for key, value in state.items():
            object.__setattr__(self, key, _system(value) if key in _SYSTEMS else value)

    def select(self, sys: ct.StateSpace, groups: tuple[str, ...] | None = None) -> ct.StateSpace:
        """``design`` or ``discrete`` with the outputs of ``groups`` only, in that order.

        Parameters
        ----------
        sys : control.StateSpace
            :attr:`design` or :attr:`discrete`.
        groups : tuple of str or None
            Output groups, from ``"v"`` (speeds [m/s]) and ``"force"``
            (coupler forces [kN]); None: :attr:`outputs`.

        Returns
        -------
        control.StateSpace
            The same system with the chosen output rows (nothing recomputed).
        """
        groups = self.outputs if groups is None else tuple(groups)
        n, nc = self.n_vehicles, self.train.n_couplers
        rows = {"v": np.arange(n), "force": n + np.arange(nc)}
        index = np.concatenate([rows[g] for g in groups]) if groups else np.zeros(0, int)
        return ct.ss(sys.A, sys.B, np.asarray(sys.C)[index], np.asarray(sys.D)[index],
                     sys.dt, states=sys.state_labels, inputs=sys.input_labels,
                     outputs=[sys.output_labels[k] for k in index], name=sys.name)

    @property
    def n_vehicles(self) -> int:
        """Number of vehicles (= inputs) n."""
        return self.train.n_vehicles

    @property
    def n_states(self) -> int:
        """States of the design model, 2n - 1."""
        return int(self.design.nstates)

    @property
    def has_dummy(self) -> bool:
        """True when ``linear`` carries seed 000's dummy state (its last state)."""
        return int(self.linear.nstates) > self.n_states

    def speed_model(self) -> ct.StateSpace:
        """``linear`` with the speed outputs only (the model the summary describes).

        Returns
        -------
        control.StateSpace
            Continuous SI model, outputs ``v[i]`` [m/s].
        """
        n = self.n_vehicles
        sys = self.linear
        return ct.ss(sys.A, sys.B, sys.C[:n], sys.D[:n], states=sys.state_labels,
                     inputs=sys.input_labels, outputs=sys.output_labels[:n], name=sys.name)

    def observer_model(self) -> ct.StateSpace:
        """The continuous SI model without the dummy state, outputs the speeds (for observers).

        Returns
        -------
        control.StateSpace
            States ``[v, delta]``, inputs ``u[i]`` [N], outputs ``v[i]`` [m/s].
        """
        n, nx = self.n_vehicles, self.n_states
        sys = self.linear
        return ct.ss(np.asarray(sys.A)[:nx, :nx], np.asarray(sys.B)[:nx],
                     np.asarray(sys.C)[:n, :nx], 0, states=sys.state_labels[:nx],
                     inputs=sys.input_labels, outputs=sys.output_labels[:n], name=sys.name)

    def force_rows(self) -> Array:
        """Coupler forces [N] as rows on the design state (no dummy), shape (n-1, 2n-1).

        Returns
        -------
        ndarray, shape (n-1, 2n-1)
            Row i gives coupler i's force deviation [N] from the design
            state ``[v, delta]`` (the coupler rows of ``linear``'s C, the
            dummy column left out): [N per m/s] on the speeds, [N/m] on
            the elongations.
        """
        n, nx = self.n_vehicles, self.n_states
        return np.asarray(self.linear.C[n:, :nx], dtype=float)

    def spacing_rows(self) -> Array:
        """Spacing deviations [m] as rows on the design state, shape (n-1, 2n-1).

        Row i picks the elongation state ``delta[i]``: the deviation of the
        spacing between vehicles i and i+1 from its equilibrium (the coupler
        elongation for a physical coupler, the gap for a virtual link).

        Returns
        -------
        ndarray, shape (n-1, 2n-1)
            Zeros with a 1 [-] at (i, n + i): the selector of ``delta[i]``.
        """
        n, nx = self.n_vehicles, self.n_states
        return np.eye(n - 1, nx, k=n)

    def loop_outputs(self) -> tuple[Array, list[str]]:
        """The output rows of every family's linear closed loop, on the design state.

        Speed deviations ``v[i]`` [m/s], coupler-force deviations ``f[i]``
        [kN], then spacing deviations ``d[i]`` [m] (:meth:`spacing_rows`).

        Returns
        -------
        (ndarray, list of str)
            Rows, shape (3n-2, 2n-1), and their labels.

        Examples
        --------
        >>> from trainctl.scenario import load_scenario
        >>> C, labels = build_model(load_scenario("crh2-dmpc")).loop_outputs()
        >>> C.shape, labels[3:5], labels[-1]
        ((10, 7), ['v[3]', 'f[0]'], 'd[2]')
        """
        n, nx = self.n_vehicles, self.n_states
        C = np.vstack([np.eye(n, nx), self.force_rows() / KN, self.spacing_rows()])
        labels = ([f"v[{i}]" for i in range(n)] + [f"f[{i}]" for i in range(n - 1)]
                  + [f"d[{i}]" for i in range(n - 1)])
        return C, labels

    def disturbance_matrix(self) -> Array:
        """Discrete input matrix of a specific-force disturbance per vehicle.

        A disturbance w_i [m/s²] (a grade or resistance error) accelerates
        vehicle i like a force m_i·w_i; by linearity of the zero-order hold
        its discrete input column is the design input column times
        m_i / 1000 (design inputs are in kN).

        Returns
        -------
        ndarray
            Shape (2n-1, n) [s per (m/s²) on speeds, m per (m/s²) on elongations].
        """
        return np.asarray(self.discrete.B, dtype=float) * (self.train.mass / KN)


def build_model(scenario: Scenario, *, outputs: tuple[str, ...] | None = None) -> DesignModel:
    """Linearise and discretise a scenario's train, once.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.
    outputs : tuple of str or None
        Output groups of the design model (``"v"``, ``"force"``); None takes
        those of the scenario's ``[controller]`` (speeds only without one).

    Returns
    -------
    DesignModel
        The models, the subsystems and the cruise equilibrium.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> model = build_model(load_scenario("crh2-dmpc"))
    >>> model.linear.nstates, model.design.nstates, model.discrete.dt
    (8, 7, 20.0)
    >>> model.design.input_labels[0], model.select(model.discrete).output_labels
    ('u[0]', ['v[0]', 'v[1]', 'v[2]', 'v[3]'])
    """
    train, cfg = scenario.train, scenario.model
    if outputs is None:
        ctl = scenario.controller
        outputs = tuple(getattr(ctl, "outputs", ("v",))) if ctl is not None else ("v",)
    linear = linearise(train, cfg.speed, method=cfg.linearisation, dummy_state=cfg.dummy_state,
                       outputs=("v", "force"))
    design = _design_system(linear, train)
    try:
        eq = equilibrium(train, cfg.speed, allocation=cfg.allocation, track=scenario.track)
    except (OverflowError, FloatingPointError) as exc:
        raise ModelError(f"build_model: the cruise equilibrium at {cfg.speed!r} m/s overflows "
                         f"({exc}). {_FINITE_HINT}") from None
    check_finite_arrays("build_model: the cruise equilibrium", f" {_FINITE_HINT}",
                        inputs=eq.inputs, coupler_forces=eq.coupler_forces,
                        elongations=eq.elongations)
    return DesignModel(
        train=train,
        settings=cfg,
        outputs=tuple(outputs),
        linear=linear,
        design=design,
        discrete=discretise(design, cfg.sample_time, method=cfg.discretisation),
        subsystems=coach_subsystems(train, cfg.speed, method=cfg.linearisation,
                                    dummy_state=cfg.dummy_state),
        equilibrium=eq,
    )


_FINITE_HINT = ("Check the masses, couplers, Davis terms, grades and the speed for values far "
                "outside a train's (see trainctl.declare.limits).")


_SYSTEMS = ("linear", "design", "discrete")


def _system_data(sys: ct.StateSpace) -> dict[str, Any]:
    return {"A": sys.A, "B": sys.B, "C": sys.C, "D": sys.D, "dt": sys.dt,
            "states": list(sys.state_labels), "inputs": list(sys.input_labels),
            "outputs": list(sys.output_labels), "name": sys.name}


def _system(data: dict[str, Any]) -> ct.StateSpace:
    return ct.ss(data["A"], data["B"], data["C"], data["D"], data["dt"], states=data["states"],
                 inputs=data["inputs"], outputs=data["outputs"], name=data["name"])


def _design_system(linear: ct.StateSpace, train: Train) -> ct.StateSpace:
    """The design model from the SI model: dummy state dropped, inputs and forces in kN."""
    n, nc = train.n_vehicles, train.n_couplers
    nx = 2 * n - 1
    scale_out = np.concatenate([np.ones(n), np.full(nc, 1 / KN)])
    A = np.asarray(linear.A, dtype=float)[:nx, :nx]
    B = np.asarray(linear.B, dtype=float)[:nx]
    C = np.asarray(linear.C, dtype=float)[:, :nx]
    return ct.ss(A, B * KN, scale_out[:, None] * C, 0, states=linear.state_labels[:nx],
                 inputs=linear.input_labels, outputs=linear.output_labels, name=linear.name)
