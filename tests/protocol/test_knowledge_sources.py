"""What a robot knows arrived in a frame or through its own sensors: the user tracker of a new
master (seed 000 Table 3's master change) and the credit of an IR reading (seed 000 Fig. 7: the
ring's announcements name the transmitter)."""

import math

import numpy as np
import pytest

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.knowledge import IRMeasurement
from petswarm_env.middleware.succession import own_user_estimate

from tests.protocol.still import make, run

HANDOVER_FIELDS = {"seq", "user", "previous"}  # messages.py: kind, sequence, user id, previous driving state


def test_a_new_masters_user_tracker_starts_from_its_own_knowledge_only():
    """At a Table 3 master change the new master's tracker starts from its own estimate (the old
    master's last status broadcast placed through its own IR fix and heading estimate of the old
    master): the old master's track and its IR fixes are poisoned just before the change and
    nothing of them shows; the handover frame carries no track."""
    env = petswarm_env.parallel_env(**{"user.scenario": "mode_change", "swarm.spawn": "at_slots", "max_cycles": 400})
    policy = make_policy("scripted", PolicySpec.from_env(env), 0)
    obs, _ = env.reset(seed=0)
    policy.reset(0)
    session, swarm = env.episode.sessions[0], env.episode.swarm
    handovers = []
    env.episode.radio.drop_filter = lambda f: (f.kind == msg.HANDOVER and handovers.append(set(f.payload))) or False
    seen = {}
    original = session._on_master_change

    def poisoned(old, new):
        session.tracker.pos, session.tracker.vel = [1e3, -1e3], [50.0, 50.0]  # the old master's track
        for other, m in list(old.know.ir.items()):  # what the old master measured of the others
            old.know.ir[other] = IRMeasurement(1e3, m.bearing_rad + 2.0, m.time_s, m.own_yaw_rad)
        # the new master's own fresh IR fix of the old one, 1.2 m ahead (in this scene the leading
        # master's IR is often older than FRESH_IR_S at the change: the estimate would be None)
        new.know.ir[old.node_id] = IRMeasurement(1.2, 0.0, new.clock.now, new.ahrs_yaw())
        original(old, new)
        now = new.clock.now
        seen.update(body=session.tracker.user_body(now), est=own_user_estimate(new, now, old.node_id))

    swarm.on_master_change = poisoned
    for _ in range(400):
        if not env.agents or seen:
            break
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
    assert seen, "no master change happened"
    assert handovers and all(fields <= HANDOVER_FIELDS for fields in handovers)
    est, body = seen["est"], seen["body"]
    assert est is not None  # the new master knew where its user was from its own measurements
    assert math.dist(body[0], est) < 0.2  # its own estimate (up to the AHRS noise of another reading)
    assert math.hypot(*body[0]) < 5.0 and math.hypot(*body[1]) < 1e-9  # nothing of the poisoned track


def test_an_ir_reading_is_credited_to_the_holder_the_receiver_heard_announced():
    """Each receiver credits the IR it measures to the holder its own ring frames named: one that
    heard nothing naming a holder drops the reading, one that heard another robot named credits it
    there (as a real one would), one that heard the holder credits the holder."""
    env = make(0)
    run(env, 2.0)
    sw = env.episode.swarm
    holder = sw.master
    deaf, misled, right = (sw.nodes[i] for i in sw.slave_ids()[:3])
    deaf.ring.holder_heard = deaf.ring.token_to = (None, -math.inf)
    misled.ring.holder_heard, misled.ring.token_to = (right.node_id, misled.clock.now), (None, -math.inf)
    right.ring.holder_heard, right.ring.token_to = (holder.node_id, right.clock.now), (None, -math.inf)
    stored = []
    for node in (deaf, misled, right):
        store = node.store_ir
        node.store_ir = lambda tx, d, b, node=node, store=store: (stored.append((node.node_id, tx)), store(tx, d, b))
    env.episode.fleet.ir_slot(holder, [])
    assert (right.node_id, holder.node_id) in stored  # the check is not vacuous: the holder's IR was measured
    assert not [s for s in stored if s[0] == deaf.node_id]
    assert [tx for rid, tx in stored if rid == misled.node_id] in ([], [right.node_id])


def test_a_robot_that_becomes_master_takes_its_users_request_from_its_tables_not_the_config():
    """The swarm's size and shape are the user's choice, told by the master in frames (the join answer,
    the member updates, a takeover): a robot that becomes master holds them as its tables say. Here
    the tables a slave holds say a column of 2 slaves at 0.7 m while the configuration says a wedge of
    4 at 1 m: what it adopts, and the slots its recovery keeps open, follow the tables."""
    from petswarm_env.middleware.formation import formation_for_mode
    from petswarm_env.middleware.succession import adopted_swarm_config

    env = make(0)
    cfg = env.cfg
    assert (cfg.swarm.num_slaves, cfg.swarm.formation, cfg.swarm.spacing_m) == (4, "wedge", 1.0)
    node = env.episode.fleet.nodes[env.episode.swarm.slave_ids()[0]]
    told = cfg.swarm.model_copy(update={"formation": "column", "spacing_m": 0.7})
    node.formation = formation_for_mode(told, 3, node.know.mode)  # what the frames told it
    node.know.members = {0: env.episode.swarm.master.node_id, 1: node.node_id, 2: env.episode.swarm.slave_ids()[1]}
    node.know.total_members = 3
    adopted = adopted_swarm_config(node)
    assert adopted.swarm.num_slaves == 2 and adopted.swarm.formation == "column"
    assert adopted.swarm.spacing_m == pytest.approx(0.7)
    node.cfg = adopted  # as the takeover commits it (succession.py, modes.py)
    assert node.recovery.open_members() == []  # its user's two slaves are there: no slot open


def test_a_slave_compares_a_plans_or_updates_number_only_with_the_same_masters():
    """Each master numbers its mode-change plans and member updates with its own count (nothing it
    could know of another master's count, nor a clock shared with it): a slave drops a repeat of the
    same master's plan or update, and takes a new master's first one although its number is lower."""
    from petswarm_env.comms.radio import BROADCAST, Frame

    env = make(0)
    sw = env.episode.swarm
    master = sw.master
    node = sw.nodes[sw.slave_ids()[0]]
    other = sw.slave_ids()[1]
    members = dict(master.know.members)
    base = dict(members=members, shape=master.formation.shape, links=master.formation.links_payload())

    def plan(src, seq, mode):
        return Frame("mode_change", src, BROADCAST, node.swarm_pan, dict(base, seq=seq, mode=mode, lf=[]))

    def update(src, seq, mode):  # an update comes from the master its table names (recovery.RecoveryManager._on_update)
        table = {m: (src if n == master.node_id else master.node_id if n == src else n) for m, n in members.items()}
        return Frame("member_update", src, BROADCAST, node.swarm_pan, dict(base, members=table, seq=seq, mode=mode))

    for make_frame, handle in ((plan, node.modes._on_mode_change), (update, node.recovery._on_update)):
        handle(make_frame(master.node_id, 7, "leading"))
        assert node.know.mode == "leading"
        handle(make_frame(master.node_id, 7, "following"))  # a repeat of the same master's: dropped
        assert node.know.mode == "leading"
        handle(make_frame(other, 1, "following"))  # another master's first, numbered lower: taken
        assert node.know.mode == "following"
        handle(make_frame(other, 1, "leading"))  # and its repeat dropped
        assert node.know.mode == "following"
