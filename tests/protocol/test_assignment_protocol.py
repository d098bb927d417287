"""swarm.assignment on the simulated 802.15.4 medium (seed 003 Algorithms 1-2 in the join protocol):
lost bids, two robots claiming one slot, stale and duplicate bids, lost status reports, loss."""

import sys

import pytest

import petswarm_env
import petswarm_env.env  # noqa: F401 (the module; the package's env() shadows its name)
from petswarm_env.comms.radio import RadioMedium
from petswarm_env.middleware import assignment as A
from petswarm_env.middleware import join as join_mod
from petswarm_env.middleware import messages as msg
from tests.protocol.test_join import slaves_consistent

CENTRAL = {"swarm.assignment": "ruta_centralized"}
DECENTRAL = {"swarm.assignment": "ruta_decentralized"}


class Frames:
    """Every frame the medium delivers (the drop filter sees each once); ``drop(frame)`` decides."""

    def __init__(self, drop=lambda f, seen: False):
        self.seen: list = []
        self._drop = drop

    def __call__(self, frame) -> bool:
        self.seen.append(frame)
        return self._drop(frame, self.seen)

    def kinds(self, kind):
        return [f for f in self.seen if f.kind == kind]


@pytest.fixture
def radio_filter(monkeypatch):
    """Install a :class:`Frames` filter on the next env's medium (it is built at reset)."""
    holder = {}

    def install(frames: Frames) -> Frames:
        class Filtered(RadioMedium):
            def __init__(self, *args, **kw):
                super().__init__(*args, **kw)
                self.drop_filter = frames

        monkeypatch.setattr(sys.modules["petswarm_env.episode"], "RadioMedium", Filtered)
        holder["frames"] = frames
        return frames

    return install


def organize(seed=0, **overrides):
    env = petswarm_env.parallel_env(**overrides)
    env.reset(seed=seed)
    return env, env.episode.swarm.organize_result


def member_of(res, rid):
    return next(m for m, n in res.members.items() if n == rid)


# -- decentralized: the auction ---------------------------------------------------------------------------


def test_without_loss_one_announcement_fills_every_slot(radio_filter):
    frames = radio_filter(Frames())
    env, res = organize(0, **DECENTRAL)
    assert res.complete and len(res.members) == 5
    announces = frames.kinds(msg.SLOT_ANNOUNCE)
    assert len(announces) == 1 and [s[0] for s in announces[0].payload["slots"]] == [1, 2, 3, 4]
    assert len(frames.kinds(msg.BID)) == 4
    slaves_consistent(env)


def test_a_lost_bid_is_a_robot_missing_from_the_round_the_open_slot_is_announced_again(radio_filter):
    lost = {}

    def drop(frame, seen):
        if frame.kind == msg.BID and frame.payload["seq"] == 1 and not lost:
            lost["robot"] = frame.src
            return True
        return False

    frames = radio_filter(Frames(drop))
    env, res = organize(0, **DECENTRAL)
    announces = frames.kinds(msg.SLOT_ANNOUNCE)
    assert len(announces) == 2
    second = announces[1].payload
    assert second["bidders"] == [lost["robot"]] and [s[0] for s in second["slots"]] == [4]  # the one slot left
    assert res.complete and member_of(res, lost["robot"]) == 4
    slaves_consistent(env)


def test_every_bid_lost_twice_the_third_announcement_fills_the_swarm(radio_filter):
    frames = radio_filter(Frames(lambda f, seen: f.kind == msg.BID and f.payload["seq"] <= 2))
    env, res = organize(0, **DECENTRAL)
    assert [f.payload["attempt"] for f in frames.kinds(msg.SLOT_ANNOUNCE)] == [1, 2, 3]
    assert res.complete and len(res.members) == 5
    slaves_consistent(env)


def test_bids_lost_at_every_announcement_leave_the_slots_open_after_max_announcements(radio_filter):
    frames = radio_filter(Frames(lambda f, seen: f.kind == msg.BID))
    with pytest.raises(RuntimeError, match="did not organize"):  # no slave at all: the env says so
        organize(0, **DECENTRAL, **{"ruta.max_announcements": 2})
    assert len(frames.kinds(msg.SLOT_ANNOUNCE)) == 2


def test_two_robots_claiming_one_slot_with_equal_utility_the_lower_id_wins(monkeypatch, radio_filter):
    # every robot offers the same utility for every slot: each slot is claimed by all of them
    monkeypatch.setattr(A, "own_utilities", lambda status, r, slots, cfg: [(int(s[0]), 0.5) for s in slots])
    radio_filter(Frames())
    env, res = organize(0, **DECENTRAL)
    slaves = sorted(n for m, n in res.members.items() if m)
    assert res.members == {0: res.members[0], **{m: rid for m, rid in zip(range(1, 5), slaves)}}
    slaves_consistent(env)  # one robot per slot, each knows its own number: no two hold one slot


def test_a_robot_bidding_twice_is_counted_once_and_a_stale_bid_is_ignored(monkeypatch, radio_filter):
    sent = join_mod.JoinManager._send_bid

    def twice(self, master, seq, utilities):  # the same bid twice, and one for an old announcement
        sent(self, master, seq, utilities)
        sent(self, master, seq, utilities)
        sent(self, master, seq - 1, [(m, 99.0) for m, _ in utilities])

    monkeypatch.setattr(join_mod.JoinManager, "_send_bid", twice)
    frames = radio_filter(Frames())
    env, res = organize(0, **DECENTRAL)
    assert len(frames.kinds(msg.SLOT_ANNOUNCE)) == 1 and res.complete
    slaves_consistent(env)
    # the winners are those of the genuine bids (the stale 99s, had they counted, would tie: lowest ids)
    genuine = {f.src: dict(f.payload["utilities"]) for f in frames.kinds(msg.BID) if f.payload["seq"] == 1}
    assert res.members[1] == max(genuine, key=lambda r: (genuine[r][1], -r))


def test_the_master_ignores_a_bid_of_another_announcement():
    jm = join_mod.JoinManager.__new__(join_mod.JoinManager)
    jm.node = type("N", (), {"node_id": 0, "clock": type("C", (), {"now": 1.0})()})()
    jm._bid_seq, jm._expect, jm._got, jm._bid_at, jm._all_in = 2, {5}, {}, {}, None
    jm._kinds = frozenset({msg.BID})  # the round waits for bids (JoinManager._collect)
    from petswarm_env.comms.radio import Frame
    jm._on_bid(Frame(msg.BID, 5, 0, 0, {"seq": 1, "utilities": [(1, 9.0)]}, 10))
    assert jm._got == {}
    jm._on_bid(Frame(msg.BID, 5, 0, 0, {"seq": 2, "utilities": [(1, 0.1)]}, 10))
    assert set(jm._got) == {5} and jm._bid_at == {5: 1.0}


# -- centralized: the status reports ----------------------------------------------------------------------


def test_centralized_every_candidate_reports_its_status_in_its_answer(radio_filter):
    frames = radio_filter(Frames())
    env, res = organize(0, **CENTRAL)
    assert res.complete and len(res.members) == 5
    assert not frames.kinds(msg.JOIN_QUERY) and not frames.kinds(msg.JOIN_ANSWER)
    reports = frames.kinds(msg.STATUS_ANSWER)
    assert sorted({f.src for f in reports}) == sorted(n for m, n in res.members.items() if m)
    p = reports[0].payload
    assert p["type"] == "petbot" and p["rate_act_ma"] == A.NO_MODULE
    assert 2490.0 < p["battery_mah"] < 2500.0  # the petbot's 2500 mAh, drained a little while it waited (sim/battery.py)
    assert reports[0].size_bytes == msg.SIZE_BYTES[msg.STATUS_ANSWER]
    slaves_consistent(env)


def test_a_lost_status_report_is_asked_for_again(radio_filter):
    lost = {}

    def drop(frame, seen):
        if frame.kind == msg.STATUS_ANSWER and not lost:
            lost["robot"] = frame.src
            return True
        return False

    frames = radio_filter(Frames(drop))
    env, res = organize(0, **CENTRAL)
    asked = [q for q in frames.kinds(msg.STATUS_QUERY) if lost["robot"] in q.payload["candidates"]]
    assert len(asked) == 2  # asked again after the lost report, and answered
    assert len([f for f in frames.kinds(msg.STATUS_ANSWER) if f.src == lost["robot"]]) == 2
    assert res.complete and lost["robot"] in res.members.values()
    slaves_consistent(env)


def test_a_robot_whose_reports_are_always_lost_is_no_candidate_the_others_organize(radio_filter):
    frames = radio_filter(Frames(lambda f, seen: f.kind == msg.STATUS_ANSWER and f.src == 1))
    env, res = organize(0, **CENTRAL)
    # robot 1 answered the scan (a candidate) but no report ever arrived: the other three join
    assert 1 in res.candidates and 1 not in res.members.values() and len(res.members) == 4 and res.complete
    assert len([q for q in frames.kinds(msg.STATUS_QUERY) if 1 in q.payload["candidates"]]) == env.cfg.protocol.max_retries + 1
    slaves_consistent(env)


# -- both under loss and collisions -------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["ruta_centralized", "ruta_decentralized"])
def test_both_organize_under_frame_loss(mode):
    for seed in range(5):
        env, res = organize(seed, **{"swarm.assignment": mode, "radio.loss_prob": 0.2, "swarm.num_slaves": 3})
        assert res.complete and len(res.members) == 4, (seed, res)
        slaves_consistent(env)


# -- the refill seam (the faults branch refills a lost member's slot through the same pipeline) -----------


@pytest.mark.parametrize("mode", ["closest", "ruta_centralized", "ruta_decentralized"])
def test_a_refill_of_one_open_slot_runs_the_same_pipeline_on_an_organized_master(mode):
    from petswarm_env.comms.radio import PAN_WAITING
    from petswarm_env.middleware.join import OrganizeResult

    env = petswarm_env.parallel_env(**{"swarm.assignment": mode, "swarm.extra_robots": 1, "protocol.join_radius_m": 4.0})
    env.reset(seed=0)
    sw = env.episode.swarm
    spare = sorted(set(sw.organize_result.candidates) - set(sw.organize_result.members.values()))
    assert len(spare) == 1
    out = {}

    def refill():  # what a refill does before its notification: scan, query, choose for slot 3
        jm, node = sw.master.join, sw.master
        node.pans = frozenset({PAN_WAITING, sw.pan})
        jm.opened_s = node.clock.now
        jm._deadline = node.clock.now + node.cfg.protocol.organize_timeout_s
        res = OrganizeResult()
        candidates, answers = yield from jm._scan_and_query(1, res)
        out["chosen"] = yield from jm._choose(candidates, answers, [3], res)
        node.pans = frozenset({sw.pan})

    env.episode.world.clock.process(refill())
    for _ in range(100):
        env.step({a: [0.0, 0.0, 0.0] for a in env.agents})
        if out:
            break
    assert out["chosen"] == ({3: spare[0]}, 1)  # only the waiting robot answers; it takes slot 3


# -- the sensing part of a slot: a robot whose ultrasonic ring failed ---------------------------------------

PLUS = {  # member 1 behind the master, covered on all four sides by 0, 2, 3, 4: its slot needs no sensing
    "swarm.formation": "custom",
    "swarm.custom_links": [
        {"robot": 1, "neighbour": 0, "offset_m": [-1.0, 0.0]}, {"robot": 2, "neighbour": 1, "offset_m": [-1.0, 0.0]},
        {"robot": 3, "neighbour": 1, "offset_m": [0.0, 1.0]}, {"robot": 4, "neighbour": 1, "offset_m": [0.0, -1.0]}],
}


@pytest.mark.parametrize("mode", ["ruta_centralized", "ruta_decentralized"])
@pytest.mark.parametrize("blind", [1, 2, 3, 4])
def test_a_robot_without_a_working_ring_takes_the_one_slot_that_needs_no_sensing(monkeypatch, mode, blind):
    from types import SimpleNamespace

    own = A.own_status

    def status(station):  # the sensor-fault hook of own_status: this robot's ultrasonic ring failed
        if station.node_id == blind:
            return own(SimpleNamespace(node_id=station.node_id, cfg=station.cfg, failed_sensors={"ultrasonic"}))
        return own(station)

    monkeypatch.setattr(A, "own_status", status)
    env, res = organize(0, **PLUS, **{"swarm.assignment": mode})
    assert res.complete and member_of(res, blind) == 1
    slaves_consistent(env)
