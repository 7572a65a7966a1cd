# Tests of what the report's figures and tables show: limits, panels, legends, numbering.
"""trainctl.report figures (time and frequency domain), plot helpers and display rules."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from matplotlib.figure import Figure

from trainctl.plots import time as plot
from trainctl.plots._common import THIN_BUCKETS, limit_lines, thin
from trainctl.report import build_report_context, collect_report_data
from trainctl.report.figures import eigenvalue_figure
from trainctl.report.figures_frequency import frequency_figures
from trainctl.report.figures_time import time_figures, vehicle_limits
from trainctl.run.analysis import run_scenario
from trainctl.scenario import load_scenario, read_scenario_text
from trainctl.sim.results import SimulationResult


def _result(name: str, *, steps: int = 30, dt: float = 20.0, iterations: int = 1,
            force_kn: float = 10.0, n: int = 4) -> SimulationResult:
    """A synthetic run of the CRH2 half train: small speed errors, motors pulling."""
    t = dt * np.arange(steps + 1)
    ref = 20.0 + 0.05 * t
    phase = np.arange(n)[:, None]
    speeds = ref + 0.1 * np.sin(t / 200.0 + phase)
    forces = force_kn * 1e3 * np.sin(t / 150.0 + np.arange(n - 1)[:, None])
    inputs = np.zeros((n, steps))
    inputs[1:3] = np.linspace(2e3, 30e3, steps)  # the motors pull, up to 30 kN
    return SimulationResult(
        time=t, states=np.zeros((2 * n, steps + 1)), velocities=speeds, coupler_forces=forces,
        inputs=inputs, reference_speed=ref, reference_acceleration=np.full(steps + 1, 0.05),
        statuses=("optimal",) * steps, iterations=np.full(steps, iterations),
        residuals=((1e-3,),) * steps, solve_times=np.full(steps, 1e-3),
        fallbacks=("",) * steps, controller_name=name, seed=0, dt=dt)


def _dense(result: SimulationResult, per_sample: int = 10) -> SimulationResult:
    """The run with a between-sample record (interpolated), as the dense-grid simulation adds."""
    t = np.linspace(result.time[0], result.time[-1], result.n_samples * per_sample + 1)
    return dataclasses.replace(
        result, dense_time=t,
        dense_states=np.array([np.interp(t, result.time, x) for x in result.states]),
        dense_coupler_forces=np.array([np.interp(t, result.time, f)
                                       for f in result.coupler_forces]),
        dense_reference_speed=np.interp(t, result.time, result.reference_speed))


def _capture(store: dict[str, Figure]) -> Any:
    """A ``make`` that keeps the drawn figures (instead of encoding them)."""
    def make(key: str, title: str, caption: str, figure: Figure) -> str:
        store[key] = figure
        return key
    return make


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("crh2-dmpc")


class TestLimits:
    """limit_lines(): axes scaled to the data, limits drawn near and named far."""

    def test_far_limit_is_named_not_drawn(self) -> None:
        """±500 kN beside ±10 kN: no line, two notes, the axes stay near the data."""
        ax = Figure().add_subplot()
        t = np.arange(11.0)
        ax.plot(t, 10 * np.sin(t))
        drawn = limit_lines(ax, t, -500e3, 500e3, labels=("limit", "limit"))
        assert drawn == []
        lo, hi = ax.get_ylim()
        assert -20 < lo < -9 and 9 < hi < 20
        notes = [a.get_text() for a in ax.texts]
        assert any("↑" in n and "500" in n for n in notes)
        assert any("↓" in n and "−500" in n for n in notes)

    def test_near_limit_is_drawn(self) -> None:
        """A traction limit falling from 48 to 15 kN over forces up to 16 kN is a line."""
        ax = Figure().add_subplot()
        t = np.arange(11.0)
        ax.plot(t, np.linspace(2, 16, 11))
        upper = np.linspace(48e3, 15e3, 11)
        drawn = limit_lines(ax, t, None, upper)
        assert len(drawn) == 1
        np.testing.assert_allclose(drawn[0].get_ydata(), upper / 1e3)
        lo, hi = ax.get_ylim()
        assert 16 < hi < 48  # clipped to the data's neighbourhood

    def test_trailer_zero_traction_is_drawn(self) -> None:
        """Zero forces, traction limit 0, braking −40 kN: the 0 line drawn, −40 named."""
        ax = Figure().add_subplot()
        t = np.arange(11.0)
        ax.plot(t, np.zeros(11))
        drawn = limit_lines(ax, t, -40e3, 0.0, labels=("braking limit", "traction limit"))
        assert [line.get_label() for line in drawn] == ["traction limit"]
        assert np.all(np.asarray(drawn[0].get_ydata()) == 0)
        assert any("braking limit" in a.get_text() and "−40" in a.get_text() for a in ax.texts)
        lo, hi = ax.get_ylim()
        assert lo < 0 < hi and hi - lo < 40


class TestTimeFigures:
    """time_figures(): small multiples, strategies overlaid, legends above the panels."""

    def test_panels_and_legends(self, scenario) -> None:
        """One panel per vehicle / coupler; the legend is the figure's, no axes legend."""
        sims = {"centralised": _result("centralised"), "ndmpc": _result("ndmpc", iterations=3)}
        figures: dict[str, Figure] = {}
        list(time_figures(scenario, sims, _capture(figures)))
        assert list(figures) == ["speed", "coupler-force", "input", "energy", "iterations"]
        assert len(figures["speed"].axes) == 1 + 4
        assert len(figures["coupler-force"].axes) == 3
        assert len(figures["input"].axes) == 4
        assert len(figures["energy"].axes) == 2
        for key, figure in figures.items():
            assert figure.legends, key
            assert all(ax.get_legend() is None for ax in figure.axes), key
            labels = [t.get_text() for t in figure.legends[0].get_texts()]
            if key != "iterations":
                assert labels[:2] == ["centralised", "ndmpc"], key

    def test_iterations_only_for_iterating_strategies(self, scenario) -> None:
        """One-iteration strategies get no iterations panel; none iterating, no figure."""
        figures: dict[str, Figure] = {}
        sims = {"centralised": _result("centralised"), "ndmpc": _result("ndmpc", iterations=3)}
        list(time_figures(scenario, sims, _capture(figures)))
        iterations = figures["iterations"]
        titles = [ax.get_title(loc="left") for ax in iterations.axes if ax.get_title(loc="left")]
        assert titles == ["ndmpc"]
        figures.clear()
        list(time_figures(scenario, {"centralised": _result("centralised")}, _capture(figures)))
        assert "iterations" not in figures

    def test_each_vehicle_its_own_limits(self, scenario) -> None:
        """Trailers (1, 4) show a zero traction limit, motors (2, 3) their envelope."""
        result = _result("centralised")
        figures: dict[str, Figure] = {}
        list(time_figures(scenario, {"centralised": result}, _capture(figures)))
        panels = figures["input"].axes
        for i, ax in enumerate(panels):
            dashed = [line for line in ax.lines if line.get_linestyle() == "--"]
            _, upper = vehicle_limits(scenario, result, i)
            traction = [line for line in dashed
                        if np.allclose(line.get_ydata(), upper / 1e3)]
            assert traction, i
            if scenario.train.vehicles[i].name == "T":
                assert np.all(upper == 0)
            assert ax.get_ylabel().startswith(f"{i + 1} ")

    def test_coupler_axes_follow_the_forces(self, scenario) -> None:
        """Forces of ±10 kN under a 500 kN limit: the axes span tens of kN, the limit named."""
        figures: dict[str, Figure] = {}
        list(time_figures(scenario, {"c": _result("c")}, _capture(figures)))
        for ax in figures["coupler-force"].axes:
            lo, hi = ax.get_ylim()
            assert hi - lo < 60
            assert any("500" in a.get_text() for a in ax.texts)


class TestDenseTraces:
    """Between-sample records are drawn when present; samples only otherwise."""

    def test_dense_line_with_sample_dots(self) -> None:
        """The trace has the dense points, the dots the sample instants."""
        sampled = _result("c")
        dense = _dense(sampled)
        ax = plot.speed_error_plot(dense, vehicle=0)
        assert len(ax.lines[0].get_xdata()) == dense.dense_time.size
        assert len(ax.lines[1].get_xdata()) == sampled.time.size
        assert ax.lines[1].get_marker() == "o"
        ax = plot.coupler_force_plot(dense, coupler=1)
        assert len(ax.lines[0].get_xdata()) == dense.dense_time.size

    def test_long_dense_trace_thinned_to_its_extremes(self) -> None:
        """A 72 000-point record is drawn with far fewer points and the same extremes."""
        sampled = _result("c", steps=60)
        dense = _dense(sampled, per_sample=1200)
        t = dense.dense_time
        wiggle = 3e3 * np.sin(2 * np.pi * t / 0.23)  # a coupler mode between the samples
        dense = dataclasses.replace(dense, dense_coupler_forces=dense.dense_coupler_forces
                                    + wiggle)
        ax = plot.coupler_force_plot(dense, coupler=0)
        y = ax.lines[0].get_ydata()
        assert len(y) <= 2 * THIN_BUCKETS + 2 < t.size
        f = dense.dense_coupler_forces[0] / 1e3
        assert y.max() == f.max() and y.min() == f.min()
        assert np.all(np.diff(ax.lines[0].get_xdata()) > 0)

    @given(st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=400), st.integers(1, 50))
    def test_thin_keeps_every_bucket_extremes(self, values, buckets) -> None:
        """Within each bucket's time span the kept points reach its min and max (brute force)."""
        y = np.array(values)
        t = np.arange(y.size, dtype=float)
        tt, yy = thin(t, y, buckets=buckets)
        assert np.all(np.isin(tt, t)) and np.array_equal(yy, y[tt.astype(int)])
        if y.size <= 2 * buckets:
            assert tt.size == y.size
            return
        edges = np.linspace(0, y.size, buckets + 1).astype(int)
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            inside = (tt >= a) & (tt < b)
            assert yy[inside].max() == y[a:b].max() and yy[inside].min() == y[a:b].min()
        assert tt[0] == 0 and tt[-1] == y.size - 1

    def test_samples_only_without_a_dense_record(self) -> None:
        """Without ``dense_time`` the trace is the samples."""
        sampled = _result("c")
        ax = plot.speed_error_plot(sampled, vehicle=0)
        assert len(ax.lines[0].get_xdata()) == sampled.time.size
        ax = plot.velocity_plot(sampled)
        assert len(ax.lines[0].get_xdata()) == sampled.time.size


def _moving(result: SimulationResult) -> SimulationResult:
    """The run with states that match its speeds: no coupler deflection, the head's
    position the trapezoid integral of its speed."""
    v = result.velocities
    n = v.shape[0]
    head = np.concatenate([[0.0], np.cumsum(0.5 * (v[0, 1:] + v[0, :-1]) * np.diff(result.time))])
    states = np.vstack([v, np.zeros((n - 1, v.shape[1])), head])
    return dataclasses.replace(result, states=states)


class TestEnergyFigure:
    """The power and cumulative-energy figure: Σ u v on the dense grid, net energy drawn."""

    def test_power_is_the_held_input_times_the_dense_speeds(self, scenario) -> None:
        """Each interval's dense points with its held inputs; a sample instant twice."""
        result = _dense(_moving(_result("c", steps=6)), per_sample=4)
        figures: dict[str, Figure] = {}
        list(time_figures(scenario, {"c": result}, _capture(figures)))
        line = figures["energy"].axes[0].lines[0]
        index = result.dense_sample_index
        times, power = [], []
        for k in range(result.n_samples):  # independently: interval by interval
            span = slice(index[k], index[k + 1] + 1)
            times.extend(result.dense_time[span])
            power.extend(result.inputs[:, k] @ result.dense_velocities[:, span])
        np.testing.assert_array_equal(line.get_xdata(), times)
        np.testing.assert_allclose(line.get_ydata(), np.array(power) / 1e6, rtol=1e-12)
        assert len(times) == result.dense_time.size + result.n_samples - 1

    def test_long_run_thinned_with_its_extremes(self, scenario) -> None:
        """A 72 000-point record: the power line is thinned and keeps its extremes."""
        result = _dense(_moving(_result("c", steps=60)), per_sample=1200)
        figures: dict[str, Figure] = {}
        list(time_figures(scenario, {"c": result}, _capture(figures)))
        y = figures["energy"].axes[0].lines[0].get_ydata()
        assert len(y) <= 2 * THIN_BUCKETS + 2 < result.dense_time.size
        v = result.dense_velocities
        assert np.isclose(y.max(), np.max(result.inputs[:, -1] @ v[:, -1201:]) / 1e6)

    def test_caption_names_the_regen_efficiency(self, scenario) -> None:
        """The caption states the units and the scenario's regen_efficiency."""
        captions: dict[str, str] = {}

        def make(key: str, title: str, caption: str, figure: Figure) -> str:
            captions[key] = caption
            return key

        efficient = scenario.replace("simulation.regen_efficiency", 0.6)
        list(time_figures(efficient, {"c": _moving(_result("c"))}, make))
        caption = captions["energy"]
        assert "regen_efficiency = 0.6" in caption and "0.6 × braking" in caption
        assert "[MW]" in caption and "[kWh]" in caption


def test_eigenvalue_legend_outside_the_circle() -> None:
    """The legend sits right of the axes, never over the unit circle."""
    figure = Figure(figsize=(7.5, 4.4), layout="constrained")
    ax = plot.eigenvalue_plot({"open loop": [0.9, 0.5 + 0.5j, 0.5 - 0.5j],
                               "closed": [0.2, -0.3]}, ax=figure.add_subplot())
    figure.canvas.draw()
    legend = ax.get_legend().get_window_extent()
    assert legend.x0 >= ax.get_window_extent().x1 - 1


@pytest.fixture(scope="module")
def context() -> dict[str, Any]:
    """crh2-dmpc's report data without simulations, and its deterministic context."""
    text, _ = read_scenario_text("crh2-dmpc")
    run = run_scenario(load_scenario("crh2-dmpc"), simulate=False)
    data = collect_report_data(run, scenario_text=text)
    return {"data": data, "ctx": build_report_context(data, deterministic=True)}


class TestContext:
    """Numbering, units and the spectral radius in the page's tables."""

    def test_vehicles_numbered_from_one(self, context) -> None:
        """Vehicles, couplers, coaches and signal names count from 1, head first."""
        ctx = context["ctx"]
        train = ctx["scenario"]["train"]
        assert [v["index"] for v in train["vehicles"]] == ["1", "2", "3", "4"]
        assert [c["between"] for c in train["couplers"]] == ["1–2", "2–3", "3–4"]
        assert [r["index"] for r in ctx["model"]["equilibrium"]] == ["1", "2", "3", "4"]
        assert ctx["model"]["couplers"][0]["index"] == "1–2"
        coach = ctx["model"]["coaches"][0]
        assert coach["index"] == "1" and coach["states"] == "v₁, δ₁"
        assert coach["matrices"][0]["subscript"] == "1,1"
        assert coach["matrices"][1]["role"] == "coupling from coach 2"

    def test_check_messages_numbered_from_one(self, context) -> None:
        """Signal names in the review's messages are 1-based, in the report and at the source.

        The eigenvector directions are stored in the details under their
        python-control names (``u_prev[3]``); the messages, which the report
        and ``analyse`` text show, name them ``u_prev₄``.
        """
        import re

        rows = context["ctx"]["checks"]["rows"]
        checks = {c["name"]: c for c in context["data"].results["checks"]}
        nash = checks["closed_loop_nash"]
        first = nash["details"]["unit_circle"][0]["direction"]
        assert set(first) <= {f"u_prev[{i}]" for i in range(4)}
        for name in first:
            index = int(name[7:-1])
            assert f"u_prev{chr(0x2081 + index)}" in nash["message"]
        indexed = re.compile(r"\w\[\d+\]")
        assert not any(indexed.search(c["message"]) for c in checks.values())
        assert not any(indexed.search(r["message"]) for r in rows)

    def test_forces_of_checks_in_kn(self, context) -> None:
        """A check whose value is a force in N is shown in kN."""
        data = context["data"]
        check = {"name": "braking_feasible", "status": "fail", "value": -250e3,
                 "threshold": -200e3, "unit": "N", "message": "vehicle[0] needs more",
                 "hint": ""}
        odd = dataclasses.replace(data, results={**data.results, "checks": [check]})
        row = build_report_context(odd, deterministic=True)["checks"]["rows"][0]
        assert (row["value"], row["threshold"], row["unit"]) == ("−250", "−200", "kN")
        assert row["message"] == "vehicle₁ needs more"

    def test_open_loop_radius_with_and_without_the_dummy(self, context) -> None:
        """Two labelled rows: the design model's radius (as in the figure) and 1 with the dummy."""
        data, ctx = context["data"], context["ctx"]
        rows = {r["name"]: r["value"] for r in ctx["model"]["overview"]}
        design = next(v for k, v in rows.items() if "design model" in k)
        dummy = next(v for k, v in rows.items() if "dummy state (its eigenvalue is 1)" in k)
        assert float(design) == pytest.approx(np.max(np.abs(data.spectra["open loop"])),
                                              rel=1e-5)
        assert dummy == "1"

    def test_linear_loop_table(self, context) -> None:
        """Without simulations the linear closed loops are still compared."""
        tables = context["ctx"]["controllers"]["tables"]
        assert [t["key"] for t in tables] == ["loops"]
        rows = tables[0]["rows"]
        assert [r["cells"][0] for r in rows] == ["centralised", "decentralised", "ndmpc"]
        assert all(" at " in r["cells"][1] for r in rows)
        assert all("pole at z = 1" in r["cells"][5] for r in rows)


def test_frequency_figures_one_per_quantity() -> None:
    """S and T figures only for loops that have them; every strategy in each legend."""
    from trainctl.analysis import analyse_closed_loops
    from trainctl.design import build_design

    loops = analyse_closed_loops(build_design(load_scenario("crh2-dmpc")))
    curves = {name: response.curves() for name, response in loops.items()}
    curves["odd"] = {**curves["ndmpc"], "frequency": {**curves["ndmpc"]["frequency"],
                                                      "sensitivity": None,
                                                      "complementary": None}}
    figures: dict[str, Figure] = {}
    list(frequency_figures(curves, _capture(figures)))
    assert list(figures) == ["sigma-speed", "sigma-force", "sensitivity", "complementary",
                             "grade-step", "string-stability"]
    string = figures.pop("string-stability")  # one row per strategy, vehicles in the legend
    assert [ax.get_title(loc="left") for ax in string.axes[::2]] == list(curves)
    assert [t.get_text() for t in string.axes[0].get_legend().get_texts()] == [
        "d[0]", "d[1]", "d[2]"]
    for key, figure in figures.items():
        names = [t.get_text() for t in figure.legends[0].get_texts()]
        expected = list(curves) if key not in ("sensitivity", "complementary") else list(loops)
        assert names == expected, key
        for ax in figure.axes:
            assert ax.get_legend() is None
    assert figures["sigma-speed"].axes[0].get_xscale() == "log"


def _inside(figure: Figure) -> bool:
    """Everything drawn (labels, legends, notes) lies on the canvas: nothing is clipped."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    box = figure.get_tightbbox(canvas.get_renderer())
    width, height = figure.get_size_inches()
    return box.x0 >= -0.01 and box.y0 >= -0.01 and box.x1 <= width + 0.01 and \
        box.y1 <= height + 0.01


def test_nothing_clipped(scenario) -> None:
    """Every report figure keeps its labels and legend inside the SVG's canvas."""
    figures: dict[str, Figure] = {}
    sims = {"centralised": _result("centralised"), "lqr.decentralised":
            _result("lqr.decentralised", iterations=2)}
    list(time_figures(scenario, sims, _capture(figures)))
    eigenvalue_figure({"open loop": np.array([0.97, 0.5 + 0.5j, 0.5 - 0.5j, -0.8 + 0.6j]),
                       "N-DMPC (10 iterations)": np.array([0.9, 0.2, -0.3])},
                      _capture(figures))
    from trainctl.analysis import analyse_closed_loops
    from trainctl.design import build_design

    loops = analyse_closed_loops(build_design(load_scenario("crh2-dmpc")))
    list(frequency_figures({k: r.curves() for k, r in loops.items()}, _capture(figures)))
    assert len(figures) == 12  # with the energy and string-stability figures
    for key, figure in figures.items():
        assert _inside(figure), key


def test_svg_paths_to_a_hundredth_of_a_point() -> None:
    """Path coordinates are written to 0.01 pt, each within 0.005 pt of matplotlib's own."""
    import io
    import re

    import matplotlib

    from trainctl.report.figures import SVG_HASH_SALT, figure_svg

    def figure() -> Figure:
        fig = Figure(figsize=(3, 2))
        x = np.linspace(0.0, 1.0, 50)
        fig.add_subplot().plot(x, np.sin(7 * x) / 3.0)
        return fig

    raw = io.StringIO()
    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": SVG_HASH_SALT}):
        figure().savefig(raw, format="svg")
    ours = str(figure_svg(figure(), prefix="p"))
    d_raw = re.findall(r' d="([^"]*)"', raw.getvalue())
    d_ours = re.findall(r' d="([^"]*)"', ours)
    assert len(d_raw) == len(d_ours)
    for a, b in zip(d_raw, d_ours, strict=True):
        x_raw = np.array(re.findall(r"-?\d+(?:\.\d+)?", a), dtype=float)
        x_ours = re.findall(r"-?\d+(?:\.\d+)?", b)
        assert all(len(v.partition(".")[2]) <= 2 for v in x_ours)
        assert np.allclose(x_raw, np.array(x_ours, dtype=float), rtol=0, atol=0.005 + 1e-9)


def test_family_figures_inside(monkeypatch) -> None:
    """The communication graph and the N-DMPC convergence figure keep everything on canvas."""
    import trainctl.plots.svg as svg
    from trainctl.controllers.mpc.report import mpc_report_figures
    from trainctl.models.graphs import make_graph
    from trainctl.plots.graph_figures import graph_figure, graph_report_data

    figures: dict[str, Figure] = {}
    graph_figure(graph_report_data(make_graph("bidirectional", 8, pinned="head")),
                 family="potential", make=lambda key, title, caption, figure, **_:
                 figures.setdefault(key, figure))
    monkeypatch.setattr(svg, "figure_svg",
                        lambda figure, *, prefix: figures.setdefault(prefix, figure))
    weights = np.logspace(-2, 3, 40)
    mpc_report_figures({"weight_sweep": {"weights": weights, "radii": 3 / (1 + weights / 2),
                                         "threshold": 2.135, "design_weight": 10.0,
                                         "unit": "per kN²"}})
    assert len(figures) == 2
    for key, figure in figures.items():
        assert figure.get_layout_engine() is None, key
        assert _inside(figure), key
