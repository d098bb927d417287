"""Independent clocks (seed 000 §3.3: the robots' clocks are independent — that is why the IR ring
passes a token). Each robot's MCU, and the belt, keeps its own time: ``local = offset + (1 + drift) · t``
(sim/clock.py ``LocalClock``; drawn per robot from the episode's seed, middleware/station.py
``mcu_clock``). Every timer of a robot's middleware counts its own seconds, every time it writes is
its own, and nothing compares one robot's time with another's: shifting each robot's offset by any
amount leaves every observation the same (the no-shared-frame check of test_no_shared_frame.py,
for time)."""

import numpy as np
import pytest

import petswarm_env
from petswarm_env.middleware import station as station_module
from petswarm_env.middleware import user_session as session_module
from petswarm_env.sim.clock import Clock, LocalClock
from tests.env.test_no_shared_frame import _trace, assert_same_observations  # one scripted run; two compared

STEPS = 100  # 10 s: organized, driving, the user walking
TOLERANCE = 1e-5  # in observation units; ages are differences of local times: only rounding may differ


def test_a_timer_of_d_local_seconds_fires_after_d_over_one_plus_drift_true_seconds():
    clock = Clock()
    fast, slow = LocalClock(clock, 123.0, 50e-6), LocalClock(clock, 7.5, -50e-6)
    fired = {}

    def wait(name, local):
        yield local.timeout(10.0)
        fired[name] = clock.now

    clock.process(wait("fast", fast))
    clock.process(wait("slow", slow))
    fast.later(2.0, lambda: fired.setdefault("fast_later", clock.now))
    slow.later(2.0, lambda: fired.setdefault("slow_later", clock.now))
    clock.run_until(20.0)
    assert fired["fast"] == 10.0 / (1 + 50e-6) and fired["slow"] == 10.0 / (1 - 50e-6)
    assert fired["fast_later"] == 2.0 / (1 + 50e-6) and fired["slow_later"] == 2.0 / (1 - 50e-6)
    # the two robots' timeouts are apart by exactly what their drifts make of 10 s: 1 ms at ±50 ppm
    assert fired["slow"] - fired["fast"] == pytest.approx(10.0 * 100e-6 / (1 - 50e-12 * 50), rel=1e-6)
    # each reads its own time: offset + (1 + drift) · t
    assert fast.now == 123.0 + (1 + 50e-6) * 20.0 and slow.now == 7.5 + (1 - 50e-6) * 20.0
    assert fast.true_time(fast.local(3.25)) == pytest.approx(3.25, abs=1e-12)


def test_a_crystal_drift_is_a_fraction():
    with pytest.raises(ValueError, match="50 ppm"):
        LocalClock(Clock(), 0.0, 50.0)  # ppm given where a fraction is meant


def test_each_robot_gets_its_own_clock_from_the_seed_within_the_configured_range():
    env = petswarm_env.parallel_env(max_cycles=5)
    env.reset(seed=3)
    cfg = env.episode.cfg.robot
    clocks = [n.clock for n in env.episode.fleet.nodes.values()]
    drifts = [c.drift for c in clocks]
    assert all(abs(d) <= cfg.clock_drift_ppm * 1e-6 for d in drifts)
    assert all(0.0 <= c.offset_s < cfg.clock_offset_max_s for c in clocks)
    assert len(set(drifts)) == len(drifts)  # independent: no two alike
    belt = env.episode.sessions[0].belt_clock
    assert belt.drift not in drifts
    env.reset(seed=3)
    assert [n.clock.drift for n in env.episode.fleet.nodes.values()] == drifts  # same seed, same clocks
    assert [n.clock.offset_s for n in env.episode.fleet.nodes.values()] == [c.offset_s for c in clocks]
    env.reset(seed=4)
    assert [n.clock.drift for n in env.episode.fleet.nodes.values()] != drifts


def test_a_robots_timers_run_on_its_own_clock():
    """Two robots of one episode: the same wait of 5 local seconds, through the clock the managers use
    (``node.clock.timeout``) and the station's bare callbacks (``node.later``), ends at different
    true times, each at 5 / (1 + its drift)."""
    env = petswarm_env.parallel_env(max_cycles=5)
    env.reset(seed=1)
    world = env.episode.world
    a, b = list(env.episode.fleet.nodes.values())[:2]
    assert a.clock.drift != b.clock.drift
    t0 = world.now
    fired = {}

    def wait(node):
        yield node.clock.timeout(5.0)
        fired[node.node_id] = world.clock.now

    for node in (a, b):
        world.clock.process(wait(node))
        node.later(5.0, lambda n=node: fired.setdefault(("later", n.node_id), world.clock.now))
    world.clock.run_until(t0 + 6.0)
    for node in (a, b):
        assert fired[node.node_id] == pytest.approx(t0 + 5.0 / (1 + node.clock.drift), abs=1e-9)
        assert fired[("later", node.node_id)] == pytest.approx(t0 + 5.0 / (1 + node.clock.drift), abs=1e-9)
    gap = fired[a.node_id] - fired[b.node_id]
    assert gap == pytest.approx(5.0 / (1 + a.clock.drift) - 5.0 / (1 + b.clock.drift), abs=1e-9)
    assert abs(gap) > 1e-6  # the drifts do show (tens of ppm of 5 s: tens to hundreds of µs)


@pytest.mark.parametrize("overrides, seed", [
    ({}, 3),
    ({"world.num_users": 2, "swarm.num_slaves": 2}, 7),
], ids=["following", "two users"])
def test_shifting_every_clocks_offset_leaves_every_observation_the_same(monkeypatch, overrides, seed):
    """If anything compared one robot's time with another's (or with the true time), moving each
    robot's clock by its own offset would change what it does: it does not (only float rounding of
    the larger numbers differs, far below any signal)."""
    straight, env = _trace(overrides, seed, STEPS)
    original = station_module.mcu_clock
    shifts = np.random.default_rng(seed).uniform(-5e4, 5e4, 64).tolist()
    made = []

    def shifted(clock, cfg, rng):
        c = original(clock, cfg, rng)
        made.append(c)
        return LocalClock(clock, c.offset_s + shifts[len(made) - 1], c.drift)

    with monkeypatch.context() as m:
        m.setattr(station_module, "mcu_clock", shifted)
        m.setattr(session_module, "mcu_clock", shifted)
        turned, env_shifted = _trace(overrides, seed, STEPS)
    assert made, "the shifted clocks were not used"
    nodes, shifted_nodes = env.episode.fleet.nodes, env_shifted.episode.fleet.nodes
    assert all(abs(nodes[i].clock.offset_s - shifted_nodes[i].clock.offset_s) > 1.0 for i in nodes)
    assert_same_observations(straight, turned, env.layout, TOLERANCE)
