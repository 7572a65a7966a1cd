"""The network model: delays drawn in the documented order, outages, losses, noise, ordering."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from scipy import stats

from trainctl.controllers.base import Measurement
from trainctl.exceptions import DimensionError, ModelError
from trainctl.models.graphs import REFERENCE, CommunicationGraph, make_graph
from trainctl.models.network import FATES, Interruption, Network, NetworkSettings, Received

DT = 0.1


def times(duration: float, dt: float = DT) -> list[float]:
    """Sample times k·dt, computed as the simulation loop computes them."""
    return [k * dt for k in range(round(duration / dt))]


def receivers_of(graph: CommunicationGraph, sender: int | str) -> np.ndarray:
    """Who hears ``sender``, from the graph's matrices (not from the network)."""
    if sender == REFERENCE:
        return np.flatnonzero(graph.pinning > 0)
    return np.flatnonzero(graph.adjacency[:, sender] > 0)


def run(net: Network, duration: float, values=None, *, reference=None) -> None:
    """send_all every sample: vehicle j sends ``values(t)[j]`` (default: 10·j + t)."""
    for t in times(duration):
        v = values(t) if values is not None else 10.0 * np.arange(net.n) + t
        net.send_all(t, v, reference=None if reference is None else reference(t))


def replay(seed, graph: CommunicationGraph, settings: NetworkSettings, sends):
    """The documented draws, redone with a second generator: (delay, lost, noise) rows."""
    rng = np.random.default_rng(seed)
    lo, hi = settings.delay_bounds()
    rows = []
    for t, sender in sends:
        k = receivers_of(graph, sender).size
        if k == 0:
            continue
        u = rng.random((k, 2))
        z = rng.standard_normal(k)
        for m in range(k):
            rows.append((t, lo + (hi - lo) * u[m, 0], u[m, 1] < settings.loss_probability,
                         settings.noise_std(sender) * z[m]))
    return rows


class TestDelays:
    """Messages arrive exactly after the delays drawn for them."""

    @pytest.mark.parametrize("topology,pinned", [("bidirectional", "all"),
                                                 ("predecessor", "head")])
    def test_arrivals_equal_independently_drawn_delays(self, topology, pinned):
        """A second generator, drawing in the documented order, gives every arrival time."""
        graph = make_graph(topology, 4, pinned=pinned)
        settings = NetworkSettings(delay_range_s=(0.0, 2.0), loss_probability=0.1,
                                   communication_noise_std=0.5, reference_noise_std=1.0)
        net = Network(settings, graph, seed=11)
        run(net, 30.0, reference=lambda t: 20.0)
        sends = [(t, s) for t in times(30.0) for s in (REFERENCE, 0, 1, 2, 3)]
        expected = replay(11, graph, settings, sends)
        log = net.history()
        assert len(log) == len(expected)
        t_sent, delay, lost, noise = (np.array(c) for c in zip(*expected, strict=True))
        np.testing.assert_array_equal(log.t_sent, t_sent)
        np.testing.assert_array_equal(log.delay, delay)
        np.testing.assert_array_equal(log.noise, noise)
        np.testing.assert_array_equal(log.fate == "lost", lost)
        delivered = log.fate == "delivered"
        np.testing.assert_array_equal(log.t_arrival[delivered], t_sent[delivered]
                                      + delay[delivered])
        assert np.all(np.isnan(log.t_arrival[~delivered]))
        assert 0.0 <= delay.min() and delay.max() <= 2.0 and delay.std() > 0.5

    def test_a_message_is_seen_from_its_arrival_on_and_not_before(self):
        """Just before t_sent + delay the receiver has nothing; at that instant it has it."""
        graph = make_graph("predecessor", 2, pinned="none")
        settings = NetworkSettings(delay_range_s=(0.5, 1.5))
        net = Network(settings, graph, seed=5)
        net.send(0.3, 0, 12.0)
        (_, delay, _, _), = replay(5, graph, settings, [(0.3, 0)])
        assert 0.5 <= delay <= 1.5
        assert net.receive(0.3 + delay - 1e-6, 1) == {}
        assert net.receive(0.3 + delay, 1) == {0: Received(0.3, 12.0)}
        assert net.history().t_arrival.tolist() == [0.3 + delay]

    @pytest.mark.parametrize("delay", [0.0, 0.3, 0.25, 2.0])
    def test_constant_delay_is_exact_at_every_sample(self, delay):
        """With delay_s, the held message is always the newest one sent at least delay ago."""
        net = Network(NetworkSettings(delay_s=delay), make_graph("bidirectional", 3,
                                                                 pinned="head"))
        samples = times(20.0)
        for k, t in enumerate(samples):
            net.send_all(t, [t, 2 * t, 3 * t], reference=-t)
            got = net.receive(t, 1)
            due = [s for s in samples[: k + 1] if s + delay <= t + 1e-9]
            if not due:
                assert got == {}
                continue
            newest = due[-1]
            assert set(got) == {0, 2}
            assert got[0] == Received(newest, newest) and got[2] == Received(newest, 3 * newest)
            assert t - got[0].t_sent == pytest.approx(math.ceil(delay / DT - 1e-9) * DT,
                                                      abs=1e-9)
        assert np.allclose(net.history().delay, delay, rtol=0, atol=0)


class TestHoldLastValue:
    """Outages and out-of-order arrivals keep the newest data by send time."""

    def test_outage_freezes_value_and_time_stamp_then_resumes(self):
        """A window [10, 20) on link 1 ← 0 freezes it; the other links carry on."""
        window = Interruption(start=10.0, end=20.0, links=[[1, 0]])
        net = Network(NetworkSettings(delay_s=0.5, interruptions=(window,)),
                      make_graph("bidirectional", 3, pinned="all"))
        held = {}
        for t in times(30.0):
            net.send_all(t, [t, 100 + t, 200 + t], reference=-t)
            held[t] = net.receive(t, 1)
        # the last message through before the window was sent at 9.4 s (arrives 9.9 s)
        frozen = [held[t][0] for t in held if 9.9 <= t < 20.5]
        assert len(frozen) > 100
        assert all(m.t_sent == pytest.approx(9.4) and m.value == pytest.approx(9.4)
                   for m in frozen)
        # the first after it was sent at 20.0 s and arrives at 20.5 s
        assert held[times(30.0)[205]][0].t_sent == pytest.approx(20.0)
        assert held[times(30.0)[-1]][0].t_sent == pytest.approx(29.4)
        # vehicle 1's other senders are not cut
        assert all(held[t][2].t_sent == pytest.approx(t - 0.5) for t in held if t >= 0.5)
        assert all(held[t][REFERENCE].t_sent == pytest.approx(t - 0.5) for t in held
                   if t >= 0.5)
        log = net.history()
        on_link = (log.receiver == 1) & (np.array(log.sender, dtype=object) == 0)
        blocked = log.fate == "blocked"
        # blocked: exactly the messages in transit at some moment of [10, 20)
        in_transit = (log.t_sent < 20.0) & (log.t_sent + 0.5 >= 10.0)
        np.testing.assert_array_equal(blocked, on_link & in_transit)
        assert np.count_nonzero(blocked) == 105  # sent at 9.5, 9.6, ..., 19.9 s

    def test_all_links_window_cuts_the_reference_too(self):
        """links = "all" blocks every link, the reference's included."""
        window = Interruption(start=2.0, end=3.0)
        net = Network(NetworkSettings(interruptions=(window,)),
                      make_graph("bidirectional", 2, pinned="all"))
        run(net, 5.0, reference=lambda t: t)
        log = net.history()
        cut = (log.t_sent >= 2.0 - 1e-12) & (log.t_sent < 3.0)
        np.testing.assert_array_equal(log.fate == "blocked", cut)
        assert {log.sender[k] for k in np.flatnonzero(cut)} == {0, 1, REFERENCE}

    def test_late_older_message_does_not_overwrite_a_newer_one(self):
        """Out of order: the second message arrives first and stays held after the first."""
        graph = make_graph("predecessor", 2, pinned="none")
        settings = NetworkSettings(delay_range_s=(0.0, 5.0))
        seed = next(s for s in range(1000)
                    if (d := [r[1] for r in replay(s, graph, settings, [(0.0, 0), (1.0, 0)])])
                    and d[0] > 1.0 + d[1] + 0.2)
        first, second = (r[1] for r in replay(seed, graph, settings, [(0.0, 0), (1.0, 0)]))
        net = Network(settings, graph, seed=seed)
        net.send(0.0, 0, 1.0)
        net.send(1.0, 0, 2.0)
        assert net.receive(1.0 + second, 1) == {0: Received(1.0, 2.0)}
        assert net.receive((1.0 + second + first) / 2, 1) == {0: Received(1.0, 2.0)}
        assert net.receive(first + 0.1, 1) == {0: Received(1.0, 2.0)}
        assert net.history().t_arrival[0] > net.history().t_arrival[1]

    def test_held_message_is_the_newest_arrived_at_every_sample(self):
        """Random delays and losses: what each vehicle holds is what the history implies."""
        graph = make_graph("all-to-all", 4, pinned="head")
        net = Network(NetworkSettings(delay_range_s=(0.0, 2.0), loss_probability=0.3),
                      graph, seed=2)
        seen = {}
        for t in times(20.0):
            net.send_all(t, np.arange(4.0) + t, reference=t)
            seen[t] = net.messages(t)
        log = net.history()
        senders = np.array(log.sender, dtype=object)
        reordered = 0
        for t, messages in seen.items():
            for receiver, sender in net.links:
                rows = np.flatnonzero((log.receiver == receiver) & (senders == sender)
                                      & (log.t_arrival <= t + 1e-9))
                if rows.size == 0:
                    assert (receiver, sender) not in messages
                    continue
                newest = rows[np.argmax(log.t_sent[rows])]
                reordered += int(np.argmax(log.t_arrival[rows]) != np.argmax(log.t_sent[rows]))
                assert messages[(receiver, sender)] == Received(log.t_sent[newest],
                                                                log.delivered[newest])
        assert reordered > 100  # the case happened often


class TestLossAndNoise:
    """Losses and noise have the stated statistics over long runs."""

    @pytest.mark.parametrize("p", [0.05, 0.3])
    def test_loss_fraction_within_a_binomial_bound(self, p):
        """The lost fraction is consistent with Binomial(m, p) (two-sided p-value > 1e-4)."""
        net = Network(NetworkSettings(loss_probability=p), make_graph("bidirectional", 4),
                      seed=7)
        run(net, 600.0, reference=lambda t: 20.0)
        log = net.history()
        m, lost = len(log), int(np.count_nonzero(log.fate == "lost"))
        assert m == 6000 * (4 + 6)
        assert stats.binomtest(lost, m, p).pvalue > 1e-4
        assert abs(lost - m * p) < 4 * math.sqrt(m * p * (1 - p))

    def test_lost_messages_never_arrive(self):
        """A lost message is never received; with p = 0 nothing is lost."""
        net = Network(NetworkSettings(loss_probability=0.5), make_graph("predecessor", 2,
                                                                        pinned="none"))
        held = set()
        for t in times(50.0):
            net.send(t, 0, t)
            held.add(net.receive(t, 1)[0].t_sent if net.receive(t, 1) else None)
        log = net.history()
        assert held - {None} == set(log.t_sent[log.fate == "delivered"].tolist())
        clean = Network(NetworkSettings(), make_graph("bidirectional", 3), seed=1)
        run(clean, 10.0, reference=lambda t: 1.0)
        assert set(clean.history().fate.tolist()) == {"delivered"}

    def test_noise_statistics(self):
        """Delivered minus sent: mean 0 and the stated std, the reference's its own."""
        net = Network(NetworkSettings(communication_noise_std=0.5, reference_noise_std=2.0),
                      make_graph("bidirectional", 4), seed=9)
        run(net, 300.0, reference=lambda t: 20.0)
        log = net.history()
        error = log.delivered - log.sent
        from_reference = np.array([s == REFERENCE for s in log.sender])
        for mask, std in ((from_reference, 2.0), (~from_reference, 0.5)):
            e = error[mask]
            m = e.size
            assert abs(e.mean()) < 4 * std / math.sqrt(m)
            assert abs(e.std() / std - 1) < 4 / math.sqrt(2 * m)
        np.testing.assert_allclose(error, log.noise, rtol=0, atol=1e-12)

    def test_reference_noise_defaults_to_communication_noise(self):
        """Without reference_noise_std the reference's messages get communication_noise_std."""
        s = NetworkSettings(communication_noise_std=0.7)
        assert s.noise_std(REFERENCE) == s.noise_std(0) == 0.7

    def test_vector_values_get_noise_per_component(self):
        """A value of shape (2,) is delivered with independent noise on each component."""
        net = Network(NetworkSettings(communication_noise_std=1.0),
                      make_graph("predecessor", 2, pinned="none"), seed=4)
        for t in times(200.0):
            net.send(t, 0, [10.0, -3.0])
        log = net.history()
        assert log.delivered.shape == (2000, 2)
        e = log.delivered - log.sent
        assert abs(np.corrcoef(e.T)[0, 1]) < 4 / math.sqrt(2000)
        with pytest.raises(DimensionError, match=r"shape of the first one sent, \(2,\)"):
            net.send(300.0, 0, 1.0)


class TestReproducibility:
    """Same seed, same history; another seed, another one; reset starts again."""

    @staticmethod
    def history(seed: int, *, reset_first: bool = False):
        net = Network(NetworkSettings(delay_range_s=(0.0, 2.0), loss_probability=0.1,
                                      communication_noise_std=1.0,
                                      interruptions=[Interruption(start=3.0, end=4.0)]),
                      make_graph("bidirectional", 4), seed=seed)
        if reset_first:
            run(net, 7.0)
            net.reset()
        run(net, 10.0, reference=lambda t: 20.0)
        return net.history().rows()

    def test_same_seed_same_history(self):
        """Every message (times, links, fates, values) is the same for the same seed."""
        assert self.history(3) == self.history(3) == self.history(3, reset_first=True)

    def test_different_seed_different_history(self):
        """Another seed draws other delays."""
        a, b = self.history(3), self.history(4)
        assert [r["delay"] for r in a] != [r["delay"] for r in b]
        assert [(r["t_sent"], r["receiver"], r["sender"]) for r in a] == \
            [(r["t_sent"], r["receiver"], r["sender"]) for r in b]

    def test_rows_are_json_safe(self):
        """Dropped messages have t_arrival and delivered None; the rest are numbers."""
        import json

        rows = self.history(3)
        json.dumps(rows)
        assert {r["fate"] for r in rows} == set(FATES)
        assert all((r["t_arrival"] is None) == (r["fate"] != "delivered") for r in rows)


class TestLinks:
    """Only the graph's links carry messages; the reference reaches the pinned vehicles."""

    def test_links_not_in_the_graph_never_deliver(self):
        """Predecessor graph: nobody hears the vehicle behind; the tail's sends go nowhere."""
        graph = make_graph("predecessor", 4, pinned="none")
        net = Network(NetworkSettings(delay_range_s=(0.0, 1.0)), graph, seed=1)
        run(net, 20.0, reference=lambda t: 1.0)
        log = net.history()
        assert {(int(i), s) for i, s in zip(log.receiver, log.sender, strict=True)} == {
            (1, 0), (2, 1), (3, 2)}
        assert net.links == ((1, 0), (2, 1), (3, 2))
        messages = net.messages(30.0)
        assert set(messages) == {(1, 0), (2, 1), (3, 2)}

    def test_reference_reaches_exactly_the_pinned_vehicles(self):
        """Pinning [1, 0, 2, 0]: the reference's messages go to vehicles 0 and 2 only."""
        graph = make_graph("bidirectional", 4, pinned=[1.0, 0.0, 2.0, 0.0])
        net = Network(NetworkSettings(), graph, seed=0)
        run(net, 1.0, reference=lambda t: 20.0)
        log = net.history()
        reached = {int(i) for i, s in zip(log.receiver, log.sender, strict=True)
                   if s == REFERENCE}
        assert reached == {0, 2}
        assert net.senders(0) == (REFERENCE, 1) and net.senders(1) == (0, 2)
        messages = net.messages(1.0)
        assert {i for i, s in messages if s == REFERENCE} == {0, 2}

    def test_messages_fill_a_measurement(self):
        """messages(t) is the mapping Measurement.messages carries: (i, j) -> (t_sent, value)."""
        net = Network(NetworkSettings(), make_graph("bidirectional", 2, pinned="head"))
        net.send_all(0.0, [20.0, 21.0], reference=20.5)
        measurement = Measurement(messages=net.messages(0.0))
        assert dict(measurement.messages or {}) == {
            (0, REFERENCE): (0.0, 20.5), (0, 1): (0.0, 21.0), (1, 0): (0.0, 20.0)}
        t_sent, value = measurement.messages[(1, 0)]  # type: ignore[index,misc]
        assert (t_sent, value) == (0.0, 20.0)


class TestErrors:
    """Bad settings and bad calls name the key, what must hold and what was given."""

    @pytest.mark.parametrize(("kwargs", "message"), [
        ({"delay_s": -0.5}, "'delay_s' must be a finite number >= 0 (got -0.5)"),
        ({"delay_range_s": (2.0, 1.0)},
         "'delay_range_s' must be [lo, hi] with lo <= hi (got [2.0, 1.0])"),
        ({"delay_range_s": (-1.0, 1.0)},
         "'delay_range_s'[0] must be a finite number >= 0 (got -1.0)"),
        ({"delay_s": 1.0, "delay_range_s": (0.0, 2.0)},
         "'delay_range_s' cannot be combined with 'delay_s'"),
        ({"loss_probability": 1.0}, "'loss_probability' must be a finite number in [0, 1) "
         "(got 1.0). A link that loses every message is no link"),
        ({"loss_probability": -0.1}, "'loss_probability' must be a finite number in [0, 1) "
         "(got -0.1)"),
        ({"communication_noise_std": -1.0}, "'communication_noise_std' must be a finite "
         "number >= 0 (got -1.0)"),
        ({"interruptions": [{"start": 5.0, "end": 4.0}]},
         "'interruptions'[0]['end'] must be greater than 'start' = 5.0 s (got 4.0)"),
        ({"interruptions": [{"start": 5.0, "end": 6.0, "links": [[1, 1]]}]},
         "'interruptions'[0]['links'][0] must join two different vehicles (got [1, 1])"),
        ({"interruptions": [{"start": 5.0, "end": 6.0, "links": [[REFERENCE, 1]]}]},
         "[0][0] must be the receiver: a vehicle index >= 0 (got 'reference'). The reference "
         "only sends"),
        ({"interruptions": [{"start": 5.0, "end": 6.0, "links": "some"}]},
         "['links'] must be 'all' or a non-empty array of [receiver, sender] pairs"),
    ])
    def test_bad_settings(self, kwargs, message):
        """Each broken rule raises a ModelError with the key path and the value given."""
        with pytest.raises(ModelError) as info:
            NetworkSettings(**kwargs)
        assert message in str(info.value)
        assert str(info.value).startswith("NetworkSettings: ")

    def test_unknown_vehicle_index(self):
        """A link naming a vehicle the formation lacks is refused when the network is built."""
        settings = NetworkSettings(interruptions=[Interruption(start=0.0, end=1.0,
                                                               links=[[1, 0], [2, 7]])])
        with pytest.raises(ModelError, match=re.escape(
                "'interruptions'[0]['links'][1][1] must be the sender: a vehicle index from 0 "
                "to 3 or 'reference' (got 7). The train has 4 vehicles, numbered from 0.")):
            Network(settings, make_graph("bidirectional", 4))

    def test_unknown_argument(self):
        """A misspelt key is a TypeError naming it."""
        with pytest.raises(TypeError, match="unexpected argument 'delay'"):
            NetworkSettings(delay=1.0)  # type: ignore[call-arg]

    def test_bad_calls(self):
        """Time going back, unknown nodes, non-finite values, a bad seed."""
        graph = make_graph("bidirectional", 2)
        net = Network(NetworkSettings(), graph)
        net.send(1.0, 0, 1.0)
        with pytest.raises(ModelError, match="must not go back in time"):
            net.receive(0.5, 1)
        with pytest.raises(ModelError, match=r"'sender' must be a vehicle index from 0 to 1 or "
                                             r"'reference' \(got 2\)"):
            net.send(1.0, 2, 1.0)
        with pytest.raises(ModelError, match=r"'receiver' must be a vehicle index"):
            net.receive(1.0, REFERENCE)  # type: ignore[arg-type]
        with pytest.raises(ModelError, match="'value' must be finite"):
            net.send(1.0, 0, math.nan)
        with pytest.raises(DimensionError, match="one value per vehicle"):
            net.send_all(1.0, [1.0, 2.0, 3.0])
        with pytest.raises(ModelError, match="'seed' must be an int >= 0"):
            Network(NetworkSettings(), graph, seed=-1)
        net.reset()
        net.receive(0.0, 1)  # time starts again after reset

    def test_send_all_checks_before_it_sends(self):
        """A bad value anywhere in send_all sends nothing, not even the reference's."""
        net = Network(NetworkSettings(), make_graph("bidirectional", 3, pinned="all"))
        with pytest.raises(ModelError, match=r"'values' must be finite \(got nan for vehicle 2\); "
                                             r"nothing was sent"):
            net.send_all(1.0, [20.0, 21.0, math.nan], reference=20.5)
        with pytest.raises(DimensionError, match=r"the shape of the first one sent, \(\)"):
            net.send_all(1.0, [[20.0, 1.0], [21.0, 1.0], [22.0, 1.0]], reference=20.5)
        assert len(net.history()) == 0
        net.send_all(1.0, [[20.0, 1.0], [21.0, 1.0], [22.0, 1.0]], reference=[20.5, 0.0])
        assert net.history().sent.shape == (3 + 4, 2)   # the first shape sent is (2,)

    def test_send_all_equals_single_sends(self):
        """send_all makes the draws and deliveries of the reference's then each vehicle's send."""
        settings = NetworkSettings(delay_range_s=(0.0, 1.0), loss_probability=0.2,
                                   communication_noise_std=0.1)
        graph = make_graph("bidirectional", 4, pinned="all")
        whole, single = Network(settings, graph, seed=5), Network(settings, graph, seed=5)
        for k in range(30):
            t = 0.25 * k
            values = 20.0 + np.sin(t + np.arange(4.0))
            whole.send_all(t, values, reference=20.0 + 0.1 * t)
            single.send(t, REFERENCE, 20.0 + 0.1 * t)
            for j in range(4):
                single.send(t, j, float(values[j]))
            assert whole.messages(t) == {link: single.receive(t, link[0])[link[1]]
                                         for link in whole.links
                                         if link[1] in single.receive(t, link[0])}
        a, b = whole.history(), single.history()
        assert np.array_equal(a.delivered, b.delivered, equal_nan=True)
        assert np.array_equal(a.fate, b.fate) and np.array_equal(a.t_arrival, b.t_arrival,
                                                                 equal_nan=True)



class TestNetworkSection:
    """[network] in a scenario file: parsed, validated against the train, in the schema."""

    @staticmethod
    def text(section: str) -> str:
        from trainctl.scenario import builtin_scenario_text

        # four subsystems, no [network] section of its own
        text = builtin_scenario_text("heavy-haul-hinf").split("[expected]")[0]
        assert "[network]" not in text
        return text.split("# What the")[0] + section

    def test_absent_section_is_none(self):
        """Without [network] the scenario has no network settings."""
        from trainctl.scenario import parse_scenario

        assert parse_scenario(self.text("")).network is None

    def test_full_section(self):
        """Every key reaches NetworkSettings; windows become Interruption objects."""
        from trainctl.scenario import parse_scenario

        scenario = parse_scenario(self.text(
            '\n[network]\ndelay_range_s = [0.0, 2.0]\nloss_probability = 0.05\n'
            'communication_noise_std = 1.0\nreference_noise_std = 0.5\n'
            '[[network.interruption]]\nstart = 100.0\nend = 130.0\n'
            '[[network.interruption]]\nstart = 200.0\nend = 260.0\n'
            'links = [[1, 0], [0, "reference"]]\n'))
        net = scenario.network
        assert net is not None
        assert net.delay_bounds() == (0.0, 2.0) and net.loss_probability == 0.05
        assert (net.noise_std(REFERENCE), net.noise_std(3)) == (0.5, 1.0)
        assert net.interruptions == (
            Interruption(start=100.0, end=130.0),
            Interruption(start=200.0, end=260.0, links=((1, 0), (0, REFERENCE))))
        network = Network(net, scenario.graph(), seed=scenario.seed)
        assert network.links[0] == (0, REFERENCE) and network.n == 4

    def test_defaults(self):
        """An empty [network] is an ideal network: no delay, loss, noise or outage."""
        from trainctl.scenario import parse_scenario

        net = parse_scenario(self.text("\n[network]\n")).network
        assert net == NetworkSettings()
        assert net.delay_bounds() == (0.0, 0.0) and net.interruptions == ()
        single = parse_scenario(self.text(
            "\n[network]\ndelay_s = 0.5\n[network.interruption]\nstart = 1.0\nend = 2.0\n"))
        assert single.network is not None
        assert single.network.interruptions == (Interruption(start=1.0, end=2.0),)

    @pytest.mark.parametrize(("section", "match"), [
        ("delay_s = -1.0", r"\[network\].delay_s must be a number >= 0 \(got -1.0\)"),
        ("delay_range_s = [2.0, 1.0]",
         r"\[network\].delay_range_s must be \[lo, hi\] with lo <= hi \(got \[2.0, 1.0\]\)"),
        ("delay_range_s = [0.0]",
         r"\[network\].delay_range_s must be an array of 2 numbers >= 0"),
        ("delay_s = 1.0\ndelay_range_s = [0.0, 2.0]",
         r"\[network\].delay_range_s cannot be combined with \[network\].delay_s"),
        ("loss_probability = 1.0",
         r"\[network\].loss_probability must be a number in \[0, 1\) \(got 1.0\)"),
        ('loss_probability = "0.1"', r"\[network\].loss_probability must be a number"),
        ("communication_noise_std = -0.1",
         r"\[network\].communication_noise_std must be a number >= 0"),
        ("delay = 1.0", r"unknown key \[network\].delay. Did you mean 'delay_s'\?"),
        ("[[network.interruption]]\nstart = 5.0\nend = 4.0",
         r"\[network.interruption\]\[0\].end must be greater than "
         r"\[network.interruption\]\[0\].start = 5.0 s \(got 4.0\)"),
        ("[[network.interruption]]\nstart = 5.0",
         r"missing required key \[network.interruption\]\[0\].end"),
        ("[[network.interruption]]\nstart = 5.0\nend = 6.0\nlinks = [[4, 0]]",
         r"\[network.interruption\]\[0\].links\[0\]\[0\] must be the receiver: a vehicle index "
         r"from 0 to 3 \(got 4\). The train has 4 vehicles, numbered from 0."),
        ("[[network.interruption]]\nstart = 5.0\nend = 6.0\nlinks = [[1, -1]]",
         r"links\[0\]\[1\] must be the sender: a vehicle index from 0 to 3 or 'reference' "
         r"\(got -1\)"),
        ('[[network.interruption]]\nstart = 5.0\nend = 6.0\nlinks = [[1, "ref"]]',
         r"links\[0\]\[1\] must be the sender"),
        ("[[network.interruption]]\nstart = 5.0\nend = 6.0\nlinks = [[1, 0], [1, 0]]",
         r"links\[1\] must not repeat an earlier pair \(got \[1, 0\] again\)"),
        ("[[network.interruption]]\nstart = 5.0\nend = 6.0\ncolour = 1",
         r"unknown key \[network.interruption\]\[0\].colour"),
    ])
    def test_bad_sections_are_scenario_errors(self, section, match):
        """Each error names the key path, what must hold and what was given."""
        from trainctl.exceptions import ScenarioError
        from trainctl.scenario import parse_scenario

        with pytest.raises(ScenarioError, match=match):
            parse_scenario(self.text(f"\n[network]\n{section}\n"))

    def test_scenario_built_in_python_checks_the_indices(self):
        """A Scenario given NetworkSettings naming a missing vehicle is refused."""
        import dataclasses

        from trainctl.scenario import parse_scenario

        scenario = parse_scenario(self.text(""))
        bad = NetworkSettings(interruptions=[Interruption(start=0.0, end=1.0, links=[[0, 9]])])
        with pytest.raises(ModelError, match=r"\[1\] must be the sender: a vehicle index from 0 "
                                             r"to 3 or 'reference' \(got 9\)"):
            dataclasses.replace(scenario, network=bad)

    def test_replace_edits_a_network_key(self):
        """Scenario.replace reaches the section like a file edit."""
        from trainctl.scenario import parse_scenario

        scenario = parse_scenario(self.text("\n[network]\ndelay_s = 0.5\n"))
        changed = scenario.replace("network.delay_s", 1.5)
        assert changed.network is not None and changed.network.delay_bounds() == (1.5, 1.5)

    def test_cli_exit_2_without_traceback(self, tmp_path, capsys):
        """trainctl analyse on a bad [network] prints one error line and exits 2."""
        from trainctl.cli.main import main

        path = tmp_path / "bad.toml"
        path.write_text(self.text("\n[network]\ndelay_range_s = [2.0, 1.0]\n"),
                        encoding="utf-8")
        assert main(["analyse", str(path)]) == 2
        err = capsys.readouterr().err
        assert "[network].delay_range_s must be [lo, hi]" in err and "Traceback" not in err

    def test_json_schema_knows_the_section(self):
        """The JSON Schema accepts a good [network] and rejects bad ones."""
        import tomllib

        import jsonschema

        from trainctl.scenario import json_schema

        schema = json_schema()
        document = tomllib.loads(self.text(""))
        document["network"] = {"delay_range_s": [0.0, 2.0], "loss_probability": 0.1,
                               "interruption": [{"start": 1.0, "end": 2.0},
                                                {"start": 3.0, "end": 4.0,
                                                 "links": [[1, 0], [0, "reference"]]}]}
        jsonschema.validate(document, schema)
        for bad in ({"loss_probability": 1.0}, {"delay_range_s": [1.0]}, {"delay": 1.0},
                    {"interruption": [{"start": 1.0}]},
                    {"interruption": [{"start": 1.0, "end": 2.0, "links": "some"}]},
                    {"interruption": [{"start": 1.0, "end": 2.0, "links": [[1, "ref"]]}]}):
            document["network"] = bad
            with pytest.raises(jsonschema.ValidationError):
                jsonschema.validate(document, schema)

    def test_readme_example_parses(self):
        """The [network] example of analyses/README.md fits its annotated example."""
        from pathlib import Path

        from trainctl.scenario import parse_scenario

        readme = (Path(__file__).resolve().parents[1] / "analyses" / "README.md").read_text(
            encoding="utf-8")
        blocks = re.findall(r"```toml\n(.*?)```", readme, re.DOTALL)
        (network,) = [block for block in blocks if block.startswith("[network]")]
        net = parse_scenario(blocks[0] + network).network
        assert net is not None and net.loss_probability == 0.01
        assert net.interruptions[0].links == ((1, 0), (0, 1))


class TestInTheSimulation:
    """simulate(..., network=...): Measurement.messages from the network, the rest unchanged."""

    @staticmethod
    def _run(network, noise=0.0):
        from trainctl.controllers.base import StepRecord
        from trainctl.models import crh2_half, equilibrium
        from trainctl.sim import Plant, ramp_profile
        from trainctl.sim.closed_loop import simulate

        train = crh2_half()
        seen = []

        class Listener:
            dt, name = 0.5, "listener"

            def reset(self):
                seen.clear()

            def step(self, t, measurement, reference):
                seen.append((t, measurement))
                return StepRecord(inputs=equilibrium(train, 50.0).inputs)

        x0 = equilibrium(train, 50.0).state(position=0.0)
        x0[0] += 0.3  # the head runs 0.3 m/s fast: its messages differ from the others'
        result = simulate(Plant(train=train), Listener(), ramp_profile(50.0, 60.0, 0.0, 10.0),
                          duration=5.0, initial_state=x0, preview_steps=0,
                          measurement_noise=noise, seed=3, network=network)
        return result, seen

    def test_constant_delay_shows_the_speed_sent_two_samples_earlier(self):
        graph = make_graph("bidirectional", 4, pinned="head")
        network = Network(NetworkSettings(delay_s=1.0), graph, seed=0)
        result, seen = self._run(network)
        for k, (t, m) in enumerate(seen):
            if k < 2:  # nothing has arrived before t = 1 s
                assert m.messages == {}
                continue
            for (rx, tx), msg in m.messages.items():
                assert msg.t_sent == pytest.approx(t - 1.0)
                if tx == REFERENCE:
                    assert rx == 0 and msg.value == pytest.approx(50.0 + 1.0 * (t - 1.0))
                else:
                    assert msg.value == pytest.approx(result.velocities[tx, k - 2])
            heard = {link for link in m.messages}
            assert heard == set(network.links)
        assert result.meta["network"] == {"delivered": len(network.links) * 10, "lost": 0,
                                          "blocked": 0, "noise_square_sum": 0.0}

    def test_no_network_and_the_noise_stream_unchanged(self):
        """With a network the measurement noise and the plant are exactly as without one."""
        base, seen = self._run(None, noise=0.05)
        assert all(m.messages is None for _, m in seen)
        graph = make_graph("bidirectional", 4, pinned="head")
        net = Network(NetworkSettings(delay_range_s=[0.0, 2.0], loss_probability=0.2,
                                      communication_noise_std=0.1), graph, seed=7)
        other, seen2 = self._run(net, noise=0.05)
        assert np.array_equal(base.states, other.states)
        assert all(np.array_equal(a.outputs, b.outputs) for (_, a), (_, b) in
                   zip(seen, seen2, strict=True))
        counts = other.meta["network"]
        assert sum(counts[fate] for fate in FATES) == len(net.links) * 10
        assert counts["lost"] > 0
