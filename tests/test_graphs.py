"""Communication graphs against closed forms and networkx's own routines."""

from __future__ import annotations

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trainctl.exceptions import ModelError
from trainctl.models.graphs import REFERENCE, CommunicationGraph, make_graph


@pytest.mark.parametrize("n", [2, 3, 8, 25])
def test_path_graph_laplacian_spectrum(n):
    """Path graph on n nodes: eigenvalues 2 − 2cos(kπ/n), k = 0..n−1 (closed form)."""
    g = make_graph("bidirectional", n)
    expected = np.sort(2.0 - 2.0 * np.cos(np.arange(n) * np.pi / n))
    assert np.allclose(np.sort(np.linalg.eigvalsh(g.laplacian())), expected, atol=1e-12)
    assert g.algebraic_connectivity() == pytest.approx(2.0 - 2.0 * np.cos(np.pi / n), abs=1e-12)


@pytest.mark.parametrize("n", [1, 2, 5, 12])
def test_complete_graph_laplacian_spectrum(n):
    """Complete graph: eigenvalues {0, n, ..., n}; λ₂ = n."""
    g = make_graph("all-to-all", n, weight=1.0)
    expected = np.array([0.0] + [float(n)] * (n - 1))
    assert np.allclose(np.sort(np.linalg.eigvalsh(g.laplacian())), expected, atol=1e-12)
    assert g.algebraic_connectivity() == pytest.approx(0.0 if n == 1 else n)


@pytest.mark.parametrize("topology", ["bidirectional", "all-to-all"])
def test_laplacian_equals_networkx_for_undirected_graphs(topology):
    """Our row-sum Laplacian equals networkx's laplacian_matrix of the undirected graph."""
    g = make_graph(topology, 6, weight=0.5)
    undirected = nx.Graph(g.to_networkx().subgraph(range(6)))
    reference = nx.laplacian_matrix(undirected, nodelist=range(6)).toarray()
    assert np.allclose(g.laplacian(), reference)


def test_laplacian_rows_act_as_consensus_errors():
    """(L x)_i = Σ_j a_ij (x_i − x_j), written out by hand for a weighted digraph."""
    a = np.array([[0.0, 2.0, 0.0], [0.5, 0.0, 0.0], [0.0, 3.0, 0.0]])
    g = CommunicationGraph(a, [1.0, 0.0, 0.0])
    x = np.array([1.0, -2.0, 4.0])
    by_hand = [2.0 * (1.0 + 2.0), 0.5 * (-2.0 - 1.0), 3.0 * (4.0 + 2.0)]
    assert np.allclose(g.laplacian() @ x, by_hand)


def test_neighbours_are_the_senders_a_vehicle_hears():
    """Row i of the adjacency, by hand for a weighted digraph; a bad index is refused, a
    negative one too (numpy would count it from the end)."""
    a = np.array([[0.0, 2.0, 0.0], [0.5, 0.0, 1.0e-3], [1.0, 3.0, 0.0]])
    g = CommunicationGraph(a, [1.0, 0.0, 0.0])
    assert [g.neighbours(i) for i in range(3)] == [(1,), (0, 2), (0, 1)]
    assert make_graph("bidirectional", 4).neighbours(np.int64(2)) == (1, 3)
    for bad in (-1, 3, 1.0, True):
        with pytest.raises(ModelError, match=r"'i' must be a vehicle index from 0 to 2"):
            g.neighbours(bad)


def test_leader_pinned_chain_has_a_spanning_tree_and_a_cut_chain_has_none():
    """Reference → head → … → tail reaches all; cutting the middle link strands the rear."""
    for topology in ("predecessor", "bidirectional"):
        g = make_graph(topology, 6, pinned="head")
        assert g.reference_reaches_all() and g.unreached() == ()
        assert g.pinned_rate() > 0
        cut = g.adjacency.copy()
        cut[3, 2] = cut[2, 3] = 0.0  # no link between vehicles 3 and 4 (1-based)
        broken = CommunicationGraph(cut, g.pinning)
        assert not broken.reference_reaches_all()
        assert broken.unreached() == (3, 4, 5)
        assert broken.pinned_rate() == pytest.approx(0.0, abs=1e-12)
        assert not broken.is_connected()


def test_direction_matters_for_the_spanning_tree():
    """Predecessor following pinned at the tail: the data flow backwards, nobody ahead hears."""
    g = make_graph("predecessor", 4, pinned=[0.0, 0.0, 0.0, 1.0])
    assert g.unreached() == (0, 1, 2)
    assert make_graph("predecessor", 4, pinned="none").unreached() == (0, 1, 2, 3)


def test_networkx_view_holds_the_information_flow():
    """Edges run sender → receiver with the weights; the reference node pins."""
    g = make_graph("predecessor", 3, pinned="head", weight=0.25)
    view = g.to_networkx()
    assert set(view.edges) == {(0, 1), (1, 2), (REFERENCE, 0)}
    assert view.edges[0, 1]["weight"] == 0.25


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 9), st.randoms(use_true_random=False))
def test_pinned_rate_positive_exactly_when_the_reference_reaches_all(n, rnd):
    """Random digraphs and pinnings: min Re λ(L + P) > 0 ⇔ spanning tree from the reference."""
    a = np.array([[0.0 if i == j or rnd.random() < 0.6 else rnd.choice([0.5, 1.0, 2.0])
                   for j in range(n)] for i in range(n)])
    p = np.array([1.0 if rnd.random() < 0.3 else 0.0 for _ in range(n)])
    g = CommunicationGraph(a, p)
    assert (g.pinned_rate() > 1e-9) == g.reference_reaches_all()


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"topology": "ring", "n": 3}, "'topology' must be one of"),
    ({"topology": "predecessor", "n": 0}, "'n' must be an integer >= 1"),
    ({"topology": "predecessor", "n": 3, "weight": -1.0}, "'weight' must be a finite number"),
    ({"topology": "predecessor", "n": 3, "pinned": "tail"}, "'pinned' must be one of"),
    ({"topology": "explicit", "n": 3}, "'adjacency' must be given exactly with"),
    ({"topology": "explicit", "n": 2, "adjacency": [[1, 0], [0, 0]]}, "zero diagonal"),
    ({"topology": "explicit", "n": 2, "adjacency": [[0, -1], [0, 0]]}, "finite weights >= 0"),
    ({"topology": "explicit", "n": 2, "adjacency": [[0, 1, 0]]}, "square matrix"),
    ({"topology": "bidirectional", "n": 3, "pinned": [1.0, 0.0]}, "3 finite weights"),
])
def test_bad_graphs_are_refused(kwargs, match):
    """Each malformed graph gives a ModelError naming what must hold."""
    with pytest.raises(ModelError, match=match):
        make_graph(**kwargs)


def test_summary_is_one_based_and_json_safe():
    """The summary numbers vehicles from 1, as the report does."""
    import json

    s = make_graph("bidirectional", 4, pinned="head").summary()
    assert s["pinned"] == [1] and s["unreached"] == [] and s["links"] == 6
    json.dumps(s)


def test_graph_figure_draws_every_link_once():
    """Bidirectional links are one double-headed arc; the reference pins each pinned vehicle."""
    from trainctl.plots.time import graph_plot

    ax = graph_plot(make_graph("bidirectional", 5, pinned="all"))
    arrows = [p for p in ax.patches if type(p).__name__ == "FancyArrowPatch"]
    assert len(arrows) == 4 + 5


class TestCommunicationSection:
    """[communication] in a scenario file: parsed, validated, defaulted, in the schema."""

    @staticmethod
    def text(section: str) -> str:
        from trainctl.scenario import builtin_scenario_text

        # four subsystems and no [communication] section of its own
        text = builtin_scenario_text("heavy-haul-hinf").split("[expected]")[0]
        assert "[communication]" not in text
        return text.split("# What the")[0] + section

    def test_default_graph_without_the_section(self):
        from trainctl.scenario import parse_scenario

        scenario = parse_scenario(self.text(""))
        assert scenario.communication is None
        g = scenario.graph()
        assert g.topology == "bidirectional" and g.pinning.tolist() == [1.0] * 4

    def test_named_topology(self):
        from trainctl.scenario import parse_scenario

        scenario = parse_scenario(self.text(
            '\n[communication]\ntopology = "predecessor"\npinned = "head"\nweight = 0.5\n'))
        g = scenario.graph()
        assert g.adjacency[1, 0] == 0.5 and g.adjacency[0, 1] == 0.0
        assert g.pinning.tolist() == [0.5, 0.0, 0.0, 0.0]

    def test_explicit_adjacency(self):
        from trainctl.scenario import parse_scenario

        rows = "[[0, 1, 0, 0], [1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0]]"
        scenario = parse_scenario(self.text(
            f'\n[communication]\ntopology = "explicit"\nadjacency = {rows}\n'))
        assert scenario.graph().adjacency[2, 1] == 2.0

    @pytest.mark.parametrize(("section", "match"), [
        ('topology = "ring"', r"\[communication\].topology must be one of"),
        ('topology = "explicit"', r"\[communication\].adjacency must be given when"),
        ('adjacency = [[0, 1], [1, 0]]', "is allowed only with"),
        ('topology = "explicit"\nadjacency = [[0, 1], [1, 0]]', "must be 4 x 4"),
        ('topology = "explicit"\nadjacency = [[0, 1, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0], '
         '[0, 0, -1, 0]]', r"adjacency\[3\]\[2\] must be a number >= 0"),
        ('pinned = "tail"', "must be one of"),
        ("colour = 1", "colour"),
    ])
    def test_bad_sections_are_scenario_errors(self, section, match):
        from trainctl.exceptions import ScenarioError
        from trainctl.scenario import parse_scenario

        with pytest.raises(ScenarioError, match=match):
            parse_scenario(self.text(f"\n[communication]\n{section}\n"))

    def test_cli_exit_2_without_traceback(self, tmp_path, capsys):
        from trainctl.cli.main import main

        path = tmp_path / "bad.toml"
        path.write_text(self.text('\n[communication]\ntopology = "explicit"\n'),
                        encoding="utf-8")
        assert main(["analyse", str(path)]) == 2
        err = capsys.readouterr().err
        assert "adjacency" in err and "Traceback" not in err

    def test_json_schema_knows_the_section(self):
        import tomllib

        import jsonschema

        from trainctl.scenario import json_schema

        schema = json_schema()
        document = tomllib.loads(self.text(""))
        document["communication"] = {"topology": "predecessor", "pinned": "head"}
        jsonschema.validate(document, schema)
        document["communication"] = {"topology": "ring"}
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(document, schema)
