"""Connectivity over interruption windows (trainctl.analysis.connectivity)."""

from __future__ import annotations

import networkx as nx
import numpy as np
import pytest

from trainctl.analysis.connectivity import (
    cut_graph,
    graph_segments,
    joint_connectivity,
    union_graph,
)
from trainctl.exceptions import ModelError
from trainctl.models.graphs import make_graph
from trainctl.models.network import Interruption


def test_segments_cover_the_run_and_split_at_every_edge() -> None:
    g = make_graph("bidirectional", 4, pinned="head")
    windows = [Interruption(start=5.0, end=15.0, links=[[2, 1]]),
               Interruption(start=10.0, end=30.0, links="all"),
               Interruption(start=50.0, end=80.0, links=[[0, "reference"]])]
    segs = graph_segments(g, windows, 60.0)
    assert [(s.start, s.end) for s in segs] == [(0.0, 5.0), (5.0, 10.0), (10.0, 15.0),
                                                (15.0, 30.0), (30.0, 50.0), (50.0, 60.0)]
    assert [s.windows for s in segs] == [(), (0,), (0, 1), (1,), (), (2,)]
    assert segs[0].unreached == ()
    assert segs[1].unreached == (2, 3)  # 2 hears only 3 now, and 3 only 2: both cut off
    assert segs[2].unreached == (0, 1, 2, 3) and segs[5].unreached == (0, 1, 2, 3)


def test_middle_cut_of_a_predecessor_chain_recovers_after_the_window() -> None:
    g = make_graph("predecessor", 4, pinned="head")
    res = joint_connectivity(g, [Interruption(start=100.0, end=130.0, links=[[2, 1]])], 600.0)
    assert res[0].cut_off == (2, 3) and res[0].recovered and res[0].recovery_time == 130.0
    assert res[0].to_dict()["cut_off_vehicles"] == [3, 4]


def test_a_cut_lasting_to_the_end_does_not_recover() -> None:
    g = make_graph("predecessor", 4, pinned="head")
    res = joint_connectivity(g, [Interruption(start=100.0, end=1e6, links=[[2, 1]])], 600.0)
    assert res[0].cut_off == (2, 3) and not res[0].recovered and res[0].recovery_time is None


def test_redundant_links_keep_everyone_reached() -> None:
    """Every vehicle pinned: cutting neighbour links cuts nobody off."""
    g = make_graph("bidirectional", 4, pinned="all")
    res = joint_connectivity(g, [Interruption(start=0.0, end=50.0,
                                              links=[[1, 0], [2, 1], [3, 2]])], 100.0)
    assert res[0].cut_off == () and res[0].recovered


def test_cut_graph_removes_links_and_pinning() -> None:
    g = make_graph("bidirectional", 3, pinned="all")
    cut = cut_graph(g, [Interruption(start=0.0, end=1.0, links=[[1, 0], [2, "reference"]])])
    assert cut.adjacency[1, 0] == 0 and cut.adjacency[0, 1] == g.adjacency[0, 1]
    assert cut.pinning.tolist() == [1.0, 1.0, 0.0]


def _reachable_after(adjacency, pinning, windows, k, duration):
    """Second route: networkx reachability on the links up at some time after window k."""
    n = len(pinning)
    end = windows[k].end
    probe = sorted({end, *[w.start for w in windows if end <= w.start < duration],
                    *[w.end for w in windows if end <= w.end < duration]})
    G = nx.DiGraph()
    G.add_nodes_from(["ref", *range(n)])
    for t in probe:
        if t >= duration:
            continue
        down = [w for w in windows if w.start <= t < w.end]
        for i in range(n):
            if pinning[i] > 0 and not any(w.blocks((i, "reference")) for w in down):
                G.add_edge("ref", i)
            for j in range(n):
                if adjacency[i, j] > 0 and not any(w.blocks((i, j)) for w in down):
                    G.add_edge(j, i)
    return set(nx.descendants(G, "ref")) >= set(range(n))


@pytest.mark.parametrize("seed", range(12))
def test_recovery_against_a_second_route(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 5
    a = (rng.random((n, n)) < 0.35).astype(float)
    np.fill_diagonal(a, 0.0)
    p = (rng.random(n) < 0.4).astype(float)
    p[0] = 1.0
    g = make_graph("explicit", n, adjacency=a, pinned=p)
    links = [(i, j) for i in range(n) for j in range(n) if a[i, j] > 0]
    windows = []
    for _ in range(3):
        start = float(rng.uniform(0, 80))
        end = float(start + rng.uniform(5, 60))
        pick = [list(links[k]) for k in rng.choice(len(links), size=min(3, len(links)),
                                                   replace=False)] if links else []
        if rng.random() < 0.3:
            pick.append([int(rng.integers(n)), "reference"])
        windows.append(Interruption(start=start, end=end, links=pick or "all"))
    for res in joint_connectivity(g, windows, 120.0):
        if res.cut_off and windows[res.window].end < 120.0:
            assert res.recovered == _reachable_after(a, p, windows, res.window, 120.0)


def test_bad_arguments() -> None:
    g = make_graph("bidirectional", 3)
    with pytest.raises(ModelError, match="'duration'"):
        graph_segments(g, [], 0.0)
    with pytest.raises(ModelError, match="at least one"):
        union_graph([])
    with pytest.raises(ModelError, match="3 vehicles"):
        union_graph([g, make_graph("bidirectional", 4)])
