"""The swarm builds its formation (seed 000 §3.4 Table 2, §3.5 Fig. 10). Waiting
robots start scattered in the master's available region with random headings (``swarm.spawn:
scattered``; ``at_slots`` keeps the old start), member numbers follow the master's estimated
distances, the slaves drive to their references from where they start, and the summary reports
how long that took (``building_time_s``)."""

import math

import numpy as np
import pytest

import petswarm_env
from petswarm.baselines.leader_follower import LeaderFollowerPolicy
from petswarm.baselines.policy import PolicySpec
from petswarm_env.config import ConfigError, load_config
from petswarm_env.metrics import BUILT_FACING_RAD, BUILT_WITHIN_M
from petswarm_env.middleware import join
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.scenarios.base import SCATTER_REACH


def _run(env, steps=None):
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    obs, _ = env.reset(seed=env.cfg.seed)
    n = 0
    while env.agents and (steps is None or n < steps):
        obs, *_ = env.step({a: policy.act(a, obs[a]) for a in env.agents})
        n += 1
    return env.episode_summary()


@pytest.mark.parametrize("key, value", [("swarm.spawn", "nowhere"), ("swarm.spawn", 1), ("user.formation_wait_s", -1.0)])
def test_the_spawn_and_the_wait_are_validated(key, value):
    with pytest.raises(ConfigError, match=key.split(".")[1]):
        load_config(overrides={key: value})


def test_scattered_robots_start_inside_the_available_region_with_random_headings():
    cfg = load_config()
    assert cfg.swarm.spawn == "scattered"
    env = petswarm_env.parallel_env(max_cycles=1)
    reach = SCATTER_REACH * cfg.protocol.join_radius_m
    headings = []
    for seed in range(5):
        env.reset(seed=seed)
        w = env.episode.world
        master = env.episode.swarm.master.node_id
        # the master organizes after its shift to the standard distance behind its user (following)
        centre = np.array([-cfg.master.distance_m, 0.0])
        for i in env.episode.swarm.slave_ids():
            assert np.hypot(*(np.asarray(w.robots[i].position) - centre)) <= reach + 1e-9  # waiting robots stand while it organizes
            headings.append(w.robots[i].heading)
        assert master not in env.episode.swarm.slave_ids()
    spread = np.std(np.unwrap(headings))
    assert spread > 1.0  # at_slots: every robot faces its user (±0.3 rad)


def test_at_slots_keeps_the_old_start_and_is_built_at_once():
    env = petswarm_env.parallel_env(**{"swarm.spawn": "at_slots", "max_cycles": 60})
    s = _run(env)
    assert s["building_time_s"] <= 3.0


@pytest.mark.parametrize("shape, slaves", [("wedge", 4), ("column", 4), ("column", 8), ("grid", 16)])
def test_a_leading_layout_starts_at_its_slots_about_where_its_master_organizes(shape, slaves):
    """``at_slots`` in leading: the robots stand about the master's organizing spot (its distance to its user
    capped inside the LF range, seed 002 §3.3), not about a spot beyond the whole formation. Before (seeds 0-4),
    the 4-slave wedge and column stood 1.2-1.4 and 1.7-3.6 m off their references at the first step (now
    0.6-0.7 and 0.7-1.0 m), and a column of 8 or a grid of 16 stood outside the 3 m join region (seed 000
    Table 1): no reset organized. Slots beyond the region still start inside it (``SPAWN_REACH``), and a
    candidate whose RSSI range reads beyond it stays out (Table 1), so a deep layout starts short of some."""
    env = petswarm_env.parallel_env(**{"swarm.mode": "leading", "swarm.formation": shape, "swarm.spawn": "at_slots",
                                       "swarm.num_slaves": slaves, "max_cycles": 5})
    env.reset(seed=0)  # organizes (raised OrganizeError before for 8 and 16)
    truth = env.episode.truth
    assert truth.swarms[0].organized
    off = [math.dist(truth.robots[idx].position, p) for idx, p in truth.reference_positions().items()]  # robot -> reference
    if slaves == 4:
        assert len(off) == slaves and max(off) < 1.0, off
    else:
        assert len(off) >= slaves - 3, off


def test_member_numbers_follow_the_masters_estimated_distances(monkeypatch):
    """Table 2 by estimated distance: the closest candidate is member 1, and so on; not robot ids."""
    seen = []
    real = join.select_joiners

    def spy(available, required):
        out = real(available, required)
        seen.append((dict(available), out))
        return out

    monkeypatch.setattr(join, "select_joiners", spy)
    by_id = 0
    for seed in range(4):
        env = petswarm_env.parallel_env(max_cycles=1, seed=seed)
        env.reset(seed=seed)
        available, out = seen[-1]
        members = env.episode.swarm.master.know.members
        slaves = [members[k] for k in sorted(members) if k != 0]
        assert slaves == out
        assert [available[r] for r in slaves] == sorted(available[r] for r in slaves)
        by_id += slaves == sorted(slaves)
    assert by_id < 4  # the robot ids do not decide


def test_the_default_swarm_builds_its_formation_and_says_when():
    env = petswarm_env.parallel_env(max_cycles=250)
    s = _run(env, steps=249)
    assert 0.0 < s["building_time_s"] < 25.0
    errors, _ = env.episode.experimenter.formation_errors(env.agents)
    assert max(errors.values()) < 2 * BUILT_WITHIN_M


def test_a_swarm_that_never_builds_reports_nan_and_the_user_walks_after_the_wait():
    env = petswarm_env.parallel_env(**{"max_cycles": 80, "user.formation_wait_s": 4.0})
    env.reset(seed=0)
    walked = None
    while env.agents:
        env.step({a: np.zeros(3, np.float32) for a in env.agents})  # nobody drives: never built
        if walked is None and env.episode.world.user.walking:
            walked = env.episode.world.now - env.episode.experimenter.organized_at_s
    s = env.episode_summary()
    assert math.isnan(s["building_time_s"])
    assert math.isnan(s["formation_hold_rmse_m"]) and s["formation_hold_steps"] == 0  # never built: nothing held
    assert math.isfinite(s["formation_rmse_m"])
    assert walked == pytest.approx(4.0, abs=0.11)


def test_the_user_waits_until_no_slave_faces_away():
    """The mixed pool (``heterogeneous``, seed 920000000, the scripted reference): every slave stood within
    ``BUILT_WITHIN_M`` of its reference at 8.0 s, a differential body facing away from its master's way; the user
    walks off only once every heading is within ``BUILT_FACING_RAD`` of its master's (16.4 s)."""
    env = petswarm_env.parallel_env(**{"user.scenario": "heterogeneous", "max_cycles": 300})
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    obs, _ = env.reset(seed=920000000)
    ep = env.episode
    before = None
    while env.agents and not ep.world.user.walking:
        before = ep.experimenter.formation_errors(env.agents)
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
    walked = ep.world.now - ep.experimenter.organized_at_s
    errors, headings = ep.experimenter.formation_errors(env.agents)
    assert walked < env.cfg.user.formation_wait_s and walked > ep.metrics.building_time_s + 2.0
    assert max(errors.values()) <= BUILT_WITHIN_M and max(map(abs, headings.values())) <= BUILT_FACING_RAD
    assert max(map(abs, before[1].values())) > BUILT_FACING_RAD  # one step before: a slave faced away


# heterogeneous: the scripted slave, written for a holonomic body, asks a differential
# body to move sideways while holding its heading; the two turns cancel and the mixed pool builds
# only after ~35 s from the scattered start (docs/results.md, "A heterogeneous swarm"). Strict: it fails
# loudly once the building gets within 25 s.
@pytest.mark.parametrize("name", SCENARIOS)
def test_the_scripted_reference_builds_the_formation_in_every_named_scenario(name):
    """Within 25 s of organizing (``max_cycles`` 250), from the scattered start. The mixed pool of ``heterogeneous``
    built only after ~35 s before its differential bodies yielded their heading to a sideways request
    (``heading_yield_mps``) and the heading exchange relayed the formation's heading (TokenRing.send_heading)."""
    s = _run(petswarm_env.parallel_env(**{"user.scenario": name, "max_cycles": 250}))
    assert math.isfinite(s["building_time_s"]), name


@pytest.mark.parametrize("seed", [0, 4])
def test_nine_slaves_build_their_filled_wedge_from_a_scattered_start(seed):
    """1 + 9 on a crowded ring (middleware/token_ring.py) in a filled wedge (middleware/formation.py):
    built within 25 s (17.8 and 14.8 s for these seeds; 11 of 20 seeds ever built, with two 4-robot
    arms on a ring where every robot answered at once)."""
    env = petswarm_env.parallel_env(**{"swarm.num_slaves": 9, "seed": seed, "max_cycles": 250})
    s = _run(env)
    assert s["slaves"] == 9 and s["slaves_missing"] == 0
    assert s["building_time_s"] <= 25.0


@pytest.mark.parametrize("seed", [42, 412])
def test_a_slave_in_the_users_shadow_finds_the_swarm(seed):
    """A slave that starts about 1 m beyond its user (the master stands 1 m behind the user, so the
    user's body blocks the master's IR and the ultrasonic ring's rays miss the user between them)
    searches (step 1d turns on the spot, then circles the user's echo) until the master's IR reaches
    it, and the formation is built within 15 s of organizing (it stood there 29-35 s before the
    search turned; `python -m petswarm.experiments.measure_building --seeds 0-199 --set user.scenario=straight`)."""
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "max_cycles": 250})
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    obs, _ = env.reset(seed=seed)
    start = env.episode.world.now
    while env.agents and not math.isfinite(env.episode.metrics.building_time_s) and env.episode.world.now - start < 15.0:
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
    assert env.episode.metrics.building_time_s <= 15.0


def test_a_leading_master_renumbers_its_members_on_the_mirror_image_when_their_sides_cross_its_user():
    """Leading, straight walk, seed 1200 (seed 000 Table 2 numbers the joining robots by RSSI distance, blind to
    their sides): two slaves stood on the sides opposite their slots, with the user among the rear slots between;
    they stalled 1.0-1.2 m off and the formation never built in 60 s (seeds 1200-1239: 4 never, 2 after 20 s).
    The master, standing with its user, renumbers its members on the mirror image of its table once its IR fixes
    show that saves at least ``REPLAN_GAIN_M`` of their total move; the experimenter's references follow the
    swarm's tables."""
    env = petswarm_env.parallel_env(**{"swarm.mode": "leading", "user.scenario": "straight", "seed": 1200})
    s = _run(env)
    master = env.episode.truth.swarms[0].master
    assert [m for _, m in master.recovery.replans] == [True] and master.recovery.mirrored
    assert math.isfinite(s["building_time_s"]) and s["building_time_s"] < 15.0, s["building_time_s"]


def test_a_following_master_renumbers_two_slaves_that_stand_on_each_others_sides():
    """Following, straight walk, seed 86: Table 2 numbered two slaves each for the other's side; behind the master
    they met head-on, their keep-outs holding them apart, 0.8-1.0 m off their slots, and the formation never built
    in 40 s. The master, standing for the building, renumbers them on its table's mirror image by the least total
    move its IR fixes measure, and the formation builds."""
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "seed": 86})
    s = _run(env)
    master = env.episode.truth.swarms[0].master
    assert [m for _, m in master.recovery.replans] == [True] and master.recovery.mirrored
    assert math.isfinite(s["building_time_s"]) and s["building_time_s"] < 15.0, s["building_time_s"]


def test_a_following_master_swaps_the_two_slaves_it_sees_when_it_cannot_see_the_rest():
    """Following, straight walk, seed 4531: the two front slaves of the wedge stood each on the other's side, 0.8 m
    off their slots, held head-on behind the master by their keep-outs; the rear slaves stood in their IR shadow, so
    the master never had a fresh fix of every member at once and the renumbering above never came: built at 53.8 s.
    The master swaps the numbers of the members it sees, among the slots they hold (middleware/replan.py,
    ``Replanning._swap_seen``), the table unchanged, and the formation builds within 15 s."""
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "seed": 4531})
    s = _run(env)
    master = env.episode.truth.swarms[0].master
    assert [m for _, m in master.recovery.replans] == [False] and not master.recovery.mirrored
    assert math.isfinite(s["building_time_s"]) and s["building_time_s"] < 15.0, s["building_time_s"]
