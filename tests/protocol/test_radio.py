"""The shared 802.15.4-like radio medium (seed 000 §3.2, §3.4; SPEC §2)."""


import numpy as np
import pytest

import petswarm_env
from petswarm_env.comms.radio import BROADCAST, PAN_WAITING, Frame, RadioMedium
from petswarm_env.config import load_config
from petswarm_env.sim.clock import Clock

PAN_A, PAN_B = 0x1001, 0x2002


class FakeStation:
    def __init__(self, clock, node_id, pans, pos):
        self.clock = clock
        self.node_id = node_id
        self.pans = frozenset(pans)
        self.pos = pos
        self.got: list[tuple[float, Frame]] = []

    def position(self):
        return self.pos

    def receive(self, frame):
        self.got.append((self.clock.now, frame))

    @property
    def frames(self):
        return [f for _, f in self.got]


def medium(seed=0, **radio_overrides):
    cfg = load_config(overrides={f"radio.{k}": v for k, v in radio_overrides.items()}).radio
    clock = Clock()
    return clock, RadioMedium(clock, cfg, np.random.default_rng(seed))


def stations(clock, radio, specs):
    out = []
    for node_id, pans, pos in specs:
        st = FakeStation(clock, node_id, pans, pos)
        radio.attach(st)
        out.append(st)
    return out


def frame(src, pan, dst=BROADCAST, kind="test", size=12, **payload):
    return Frame(kind, src, dst, pan, dict(payload), size)


def test_airtime_formula():
    _, radio = medium()
    cfg = radio.cfg
    for size in (0, 4, 12, 100):
        expected = (cfg.frame_overhead_bytes + size) * 8.0 / cfg.bitrate_bps
        assert radio.airtime_s(frame(1, PAN_A, size=size)) == pytest.approx(expected)
    assert radio.airtime_s(frame(1, PAN_A, size=12)) == pytest.approx(29 * 8 / 250_000)


def test_frame_arrives_after_latency_turnaround_and_airtime():
    clock, radio = medium(min_be=0, max_be=0)  # no random backoff
    a, b = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (1, 0))])
    f = frame(1, PAN_A, size=20)
    radio.send(a, f)
    clock.run(until=1.0)
    assert len(b.got) == 1
    cfg = radio.cfg
    assert b.got[0][0] == pytest.approx(cfg.latency_s + cfg.turnaround_s + radio.airtime_s(f))
    assert a.got == []  # a sender does not hear itself
    assert radio.stats.frames_sent == 1


def test_transmit_is_send_of_the_frame_built_from_its_fields():
    """A station's send (``RadioMedium.transmit``: the medium builds the frame) puts on the air and
    delivers what ``send`` of the same frame does: the same frames, at the same times, with the same
    RSSI estimates, from the same draws."""
    got = []
    for way in ("send", "transmit"):
        clock, radio = medium(seed=3, loss_prob=0.2)
        a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (1, 0)), (3, {PAN_A}, (0, 2))])
        for k in range(6):
            src, dst = (a, BROADCAST) if k % 2 == 0 else (b, 3)
            fields = ("test", src.node_id, dst, PAN_A, {"k": k}, 10 + k)
            if way == "send":
                radio.send(src, Frame(*fields))
            else:
                radio.transmit(*fields)
        clock.run(until=1.0)
        got.append([(st.node_id, t, f) for st in (a, b, c) for t, f in st.got])
    assert got[0] == got[1] and len(got[0]) >= 5
    assert {f.src for _, _, f in got[1]} == {1, 2} and all(f.rx_distance_est_m > 0 for _, _, f in got[1])


def test_broadcast_reaches_same_pan_only():
    clock, radio = medium()
    sender, *same = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (1, 0)), (3, {PAN_A}, (0, 2)), (4, {PAN_WAITING, PAN_A}, (2, 2))])
    other = stations(clock, radio, [(5, {PAN_B}, (1, 1)), (6, {PAN_WAITING}, (-1, 0))])
    radio.send(sender, frame(1, PAN_A, payload_id=7))
    clock.run(until=1.0)
    for st in same:
        assert len(st.frames) == 1
        assert st.frames[0].payload == {"payload_id": 7}
        assert st.frames[0].pan == PAN_A
    for st in other:
        assert st.got == []
    assert radio.stats.foreign_pan_dropped == 2
    assert radio.stats.receptions == 3


def test_unicast_reaches_only_its_destination():
    clock, radio = medium()
    a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (1, 0)), (3, {PAN_A}, (0, 1))])
    radio.send(a, frame(1, PAN_A, dst=3))
    clock.run(until=1.0)
    assert b.got == [] and len(c.got) == 1


def test_out_of_range_station_hears_nothing():
    clock, radio = medium()
    a, near, far = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (5, 0)), (3, {PAN_A}, (40, 0))])
    assert radio.cfg.range_m < 40
    radio.send(a, frame(1, PAN_A))
    clock.run(until=1.0)
    assert len(near.got) == 1 and far.got == []


def test_rssi_distance_estimate_is_exact_without_shadowing():
    clock, radio = medium(rssi_shadowing_db=0.0)
    a, b = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (3.0, 4.0))])
    radio.send(a, frame(1, PAN_A))
    clock.run(until=1.0)
    assert b.frames[0].rx_distance_est_m == pytest.approx(5.0)


def test_rssi_distance_estimate_is_noisy_with_shadowing():
    clock, radio = medium(rssi_shadowing_db=2.0)
    a, b = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (2.0, 0.0))])
    for _ in range(40):
        radio.send(a, frame(1, PAN_A))
    clock.run(until=5.0)
    est = np.array([f.rx_distance_est_m for f in b.frames])
    assert len(est) == 40
    assert est.std() > 0.05
    assert np.median(est) == pytest.approx(2.0, rel=0.2)


def test_simultaneous_senders_collide_at_a_third_station():
    # zero backoff: both CCAs happen at the same instant, neither senses the other
    clock, radio = medium(min_be=0, max_be=0)
    a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (2, 0)), (3, {PAN_A}, (1, 1))])
    radio.send(a, frame(1, PAN_A))
    radio.send(b, frame(2, PAN_A))
    clock.run(until=1.0)
    assert c.got == []
    assert a.got == [] and b.got == []  # half duplex: each was transmitting
    assert radio.stats.frames_sent == 2
    assert radio.stats.frames_collided == 4
    assert radio.stats.frames_lost == 0


def test_partial_overlap_destroys_the_earlier_ending_frame():
    clock, radio = medium(min_be=0, max_be=0)
    a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (2, 0)), (3, {PAN_A}, (1, 1))])
    radio.send(a, frame(1, PAN_A))
    clock.process(_send_later(clock, radio, b, frame(2, PAN_A), 0.5 * radio.cfg.turnaround_s))
    clock.run(until=1.0)
    assert 1 not in [f.src for f in c.frames]
    assert radio.stats.frames_collided >= 2


def test_start_inside_turnaround_still_collides():
    clock, radio = medium(min_be=0, max_be=0)
    a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (2, 0)), (3, {PAN_A}, (1, 1))])
    radio.send(a, frame(1, PAN_A))
    late = 0.5 * radio.cfg.turnaround_s  # b's CCA falls inside a's turnaround: not sensed
    clock.process(_send_later(clock, radio, b, frame(2, PAN_A), late))
    clock.run(until=1.0)
    assert c.got == []
    assert radio.stats.frames_collided >= 2


def _send_later(clock, radio, st, f, delay):
    yield clock.timeout(delay)
    radio.send(st, f)


def test_one_sender_alone_goes_through():
    clock, radio = medium(min_be=0, max_be=0)
    a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (2, 0)), (3, {PAN_A}, (1, 1))])
    radio.send(a, frame(1, PAN_A))
    clock.run(until=1.0)
    assert len(c.got) == 1 and len(b.got) == 1
    assert radio.stats.frames_collided == 0


def test_csma_defers_to_a_frame_already_on_the_air():
    clock, radio = medium(seed=3)  # default backoff exponents
    a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (2, 0)), (3, {PAN_A}, (1, 1))])
    long = frame(1, PAN_A, size=100)  # ~3.7 ms on the air
    radio.send(a, long)
    # b wants to send while a is well into its transmission
    start = radio.cfg.latency_s + radio.cfg.backoff_slot_s * 3 + radio.cfg.turnaround_s + 0.001
    clock.process(_send_later(clock, radio, b, frame(2, PAN_A), start))
    clock.run(until=1.0)
    assert radio.stats.frames_collided == 0
    assert [f.src for f in c.frames] == [1, 2]
    t_a, t_b = c.got[0][0], c.got[1][0]
    assert t_b - t_a >= radio.airtime_s(frame(2, PAN_A))  # b started only after a had finished


def test_busy_channel_drops_the_frame_after_max_backoffs():
    # zero backoff: the re-assessments happen at once, the channel stays busy, the MAC gives up
    clock, radio = medium(min_be=0, max_be=0)
    a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (2, 0)), (3, {PAN_A}, (1, 1))])
    radio.send(a, frame(1, PAN_A, size=100))
    clock.process(_send_later(clock, radio, b, frame(2, PAN_A), 0.001))
    clock.run(until=1.0)
    assert radio.stats.frames_dropped_busy == 1
    assert [f.src for f in c.frames] == [1]


def test_loss_prob_one_loses_everything():
    clock, radio = medium(loss_prob=1.0)
    a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (2, 0)), (3, {PAN_A}, (1, 1))])
    for _ in range(5):
        radio.send(a, frame(1, PAN_A))
    clock.run(until=1.0)
    assert b.got == [] and c.got == []
    assert radio.stats.frames_sent == 5
    assert radio.stats.frames_lost == 10
    assert radio.stats.receptions == 10


def test_loss_prob_is_independent_per_reception():
    clock, radio = medium(loss_prob=0.3)
    a, *rx = stations(clock, radio, [(1, {PAN_A}, (0, 0))] + [(i, {PAN_A}, (1, i)) for i in range(2, 6)])
    for _ in range(100):
        radio.send(a, frame(1, PAN_A))
    clock.run(until=5.0)
    st = radio.stats
    assert st.receptions == 400
    assert 0.2 < st.frames_lost / st.receptions < 0.4
    assert sum(len(s.got) for s in rx) == 400 - st.frames_lost


def test_drop_filter_removes_a_frame_for_everyone():
    clock, radio = medium()
    a, b, c = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (2, 0)), (3, {PAN_A}, (1, 1))])
    radio.drop_filter = lambda f: f.payload.get("n") == 1
    for n in range(3):
        radio.send(a, frame(1, PAN_A, n=n))
    clock.run(until=1.0)
    for st in (b, c):
        assert [f.payload["n"] for f in st.frames] == [0, 2]
    assert radio.stats.frames_sent == 3  # the dropped frame still used the air
    assert radio.stats.frames_lost == 0


def test_one_station_sends_in_order_one_at_a_time():
    clock, radio = medium(seed=5)
    a, b = stations(clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (1, 0))])
    sizes = [4, 30, 8, 60, 12, 4]
    for i, size in enumerate(sizes):
        radio.send(a, frame(1, PAN_A, size=size, i=i))
    clock.run(until=1.0)
    assert [f.payload["i"] for f in b.frames] == list(range(len(sizes)))
    assert radio.stats.frames_collided == 0  # a station never overlaps with itself
    times = [t for t, _ in b.got]
    cfg = radio.cfg
    for k in range(1, len(times)):
        # frame k only starts (latency, backoff, turnaround) after frame k-1 has ended
        min_gap = cfg.latency_s + cfg.turnaround_s + radio.airtime_s(frame(1, PAN_A, size=sizes[k]))
        assert times[k] - times[k - 1] >= min_gap - 1e-12


def test_two_pans_on_one_medium_never_mix():
    """Two swarms (two users) share the medium: each only gets its own PAN's frames."""
    clock, radio = medium(seed=11)
    a1, a2, b1, b2 = stations(
        clock, radio, [(1, {PAN_A}, (0, 0)), (2, {PAN_A}, (1, 0)), (3, {PAN_B}, (0, 1)), (4, {PAN_B}, (1, 1))]
    )
    rng = np.random.default_rng(0)

    def chatter(st, pan, peer):
        for k in range(40):
            yield clock.timeout(float(rng.uniform(0.0, 0.01)))
            radio.send(st, frame(st.node_id, pan, dst=peer if k % 2 else BROADCAST, k=k))

    for st, pan, peer in ((a1, PAN_A, 2), (a2, PAN_A, 1), (b1, PAN_B, 4), (b2, PAN_B, 3)):
        clock.process(chatter(st, pan, peer))
    clock.run(until=5.0)
    for st, pan, peer in ((a1, PAN_A, 2), (a2, PAN_A, 1), (b1, PAN_B, 4), (b2, PAN_B, 3)):
        assert st.frames, f"station {st.node_id} received nothing"
        assert all(f.pan == pan and f.src == peer for f in st.frames)
    assert radio.stats.foreign_pan_dropped > 0
    assert radio.stats.frames_collided > 0  # different PANs still share (and fight for) the air


def test_no_foreign_pan_frame_processed_in_an_episode():
    env = petswarm_env.parallel_env(**{"swarm.other_user_robots": 1, "swarm.extra_robots": 1, "max_cycles": 200})
    env.reset(seed=0)
    for _ in range(200):
        _, _, _, trunc, _ = env.step({})
    assert all(trunc.values())
    assert env.episode.swarm.foreign_pan_frames_processed() == 0
    assert sum(n.counters["frames_handled"] for n in env.episode.swarm.nodes.values()) > 1000
    assert env.episode.radio.stats.frames_sent > 1000
    assert env.episode_summary()["foreign_pan_frames_processed"] == 0


def test_no_foreign_pan_frame_processed_under_loss_one_user():
    """``foreign_pan_frames_processed`` counts only frames of another PAN that a
    robot processed. The organizing master listens on the PAN it forms (a retried joining
    notification is acknowledged there): those frames are its own PAN's, never foreign. Before,
    the count was non-zero in 7 of 25 such episodes."""
    env = petswarm_env.parallel_env(**{"radio.loss_prob": 0.2, "max_cycles": 10})
    counts, handled = [], 0
    for seed in range(25):
        env.reset(seed=seed)
        for _ in range(10):
            env.step({})
        counts.append(env.episode_summary()["foreign_pan_frames_processed"])
        handled += sum(n.counters["frames_handled"] for n in env.episode.fleet.nodes.values())
    assert counts == [0] * 25
    assert handled > 25 * 100


def test_two_swarms_under_loss_drop_each_others_frames_in_the_mac(monkeypatch):
    """Two users at loss 0.2: each swarm's frames reach the other's robots, whose MAC drops them;
    none is processed (the spy sees every frame a robot processes)."""
    from petswarm_env.middleware.node import Node  # every station is a Node (a Python subclass)

    processed = []
    original = Node._handle

    def spy(self, handler, frame):
        processed.append((self.node_id, frame.pan))
        return original(self, handler, frame)

    monkeypatch.setattr(Node, "_handle", spy)
    env = petswarm_env.parallel_env(**{"world.num_users": 2, "radio.loss_prob": 0.2, "max_cycles": 30})
    for seed in (0, 3, 6):
        env.reset(seed=seed)
        processed.clear()
        dropped = env.episode.radio.stats.foreign_pan_dropped
        for _ in range(30):
            env.step({})
        pan_of = {i: sw.pan for sw in env.episode.swarms for i in sw.member_ids()}
        assert processed and all(pan == pan_of[i] for i, pan in processed if i in pan_of and pan != PAN_WAITING)
        assert env.episode.radio.stats.foreign_pan_dropped > dropped
        assert env.episode_summary()["foreign_pan_frames_processed"] == 0
