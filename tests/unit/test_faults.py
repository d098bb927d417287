"""Fault state and fault effects (docs/faults.md; petswarm_env/sim/faults.py, petswarm_env/runtime.py)."""

import math

import numpy as np
import pytest

import petswarm_env
from petswarm_env.comms.radio import BROADCAST
from petswarm_env.config import load_config
from petswarm_env.sim.faults import KINDS, FaultState, Faults

STILL = {"user.start_delay_s": 100.0, "swarm.spawn": "at_slots"}  # the user stands, the members at their slots


def test_fault_kinds_are_the_configs():
    from petswarm_env.config import FAULT_KINDS

    assert KINDS == FAULT_KINDS


@pytest.mark.parametrize("kind, off", [
    ("dead", {"powered", "radio_ok", "ir_ok", "ultrasonic_ok", "ahrs_ok"}),
    ("battery", {"powered", "radio_ok", "ir_ok", "ultrasonic_ok", "ahrs_ok"}),
    ("radio_silent", {"radio_ok"}),
    ("ir", {"ir_ok"}),
    ("ultrasonic", {"ultrasonic_ok"}),
    ("ahrs", {"ahrs_ok"}),
])
def test_each_kind_switches_off_its_parts_and_clears(kind, off):
    state = FaultState()
    state.set(kind, True)
    flags = ("powered", "radio_ok", "ir_ok", "ultrasonic_ok", "ahrs_ok")
    assert {f for f in flags if not getattr(state, f)} == off
    state.set(kind, False)
    assert all(getattr(state, f) for f in flags)


def test_battery_goes_through_the_same_entry_point_as_dead():
    states = [FaultState(), FaultState()]
    faults = Faults(states)
    seen = []
    faults.on_change.append(lambda robot, kind, on: seen.append((robot, kind, on)))
    faults.inject(1, "battery", 3.0, "slave")
    assert seen == [(1, "battery", True)] and not faults.powered(1) and faults.powered(0)
    assert faults.log[0].kind == "battery" and faults.log[0].time_s == 3.0
    assert not faults.ultrasonic_ok(1) and faults.sensing_health(1) == {"ultrasonic": False, "ir": False, "ahrs": False}
    with pytest.raises(ValueError, match="unknown fault kind"):
        states[0].set("zap", True)


def _env(**overrides):
    env = petswarm_env.parallel_env(**{**STILL, **overrides})
    env.reset(seed=0)
    return env


def _steps(env, n):
    for _ in range(n):
        env.step({a: np.zeros(3, np.float32) for a in env.agents})


def test_no_fault_config_means_no_runtime_change():
    cfg = load_config()
    assert cfg.faults == [] and cfg.arrivals == [] and cfg.faults_random.rate_per_min == 0
    env = _env()
    _steps(env, 20)
    s = env.episode_summary()
    assert s["faults_injected"] == 0 and s["faults_detected"] == 0 and math.isnan(s["detection_time_s"])
    assert s["reassignments"] == 0 and s["arrivals_joined"] == 0 and s["slots_unfilled_s"] == 0.0


def test_radio_silent_robot_sends_and_hears_nothing():
    env = _env(faults=[{"at_s": 0.5, "robot": 2, "kind": "radio_silent"}])
    sent = []
    env.episode.radio.drop_filter = lambda f: sent.append(f.src) or False
    _steps(env, 10)
    node = env.episode.fleet.nodes[2]
    heard = node.counters["frames_handled"]
    sent.clear()
    _steps(env, 5)
    assert 2 not in sent and node.counters["frames_handled"] == heard
    node.send("status", dst=BROADCAST, velocity=(0, 0, 0))  # even a direct send leaves nothing
    assert 2 not in sent


def test_ir_fault_stops_transmission_and_reception():
    env = _env(faults=[{"at_s": 0.5, "robot": 1, "kind": "ir"}])
    _steps(env, 10)
    one = env.episode.fleet.nodes[1]
    others = [env.episode.fleet.nodes[i] for i in env.episode.swarm.slave_ids() if i != 1]
    mine = {k: v.time_s for k, v in one.know.ir.items()}
    theirs = [o.know.ir[1].time_s for o in others if 1 in o.know.ir]
    _steps(env, 20)
    # nothing measured any more (the robot may have found its IR broken and left the swarm, forgetting it)
    assert all(mine.get(k) == v.time_s for k, v in one.know.ir.items())
    assert [o.know.ir[1].time_s for o in others if 1 in o.know.ir] == theirs  # nobody measures it


def test_ultrasonic_fault_reads_max_range_and_ahrs_fault_freezes_the_yaw():
    env = _env(faults=[{"at_s": 0.5, "robot": 1, "kind": "ultrasonic"}, {"at_s": 0.5, "robot": 2, "kind": "ahrs"}])
    _steps(env, 8)
    assert np.all(env.episode.sensors.ranges[1] == env.cfg.robot.ultrasonic.max_range_m)
    assert not env.episode.runtime.faults.ultrasonic_ok(1) and env.episode.runtime.faults.ultrasonic_ok(2)
    robot = env.episode.world.robots[2]
    yaws = {robot.ahrs_yaw(env.episode.world.now + k) for k in range(5)}
    assert len(yaws) == 1
    assert env.episode_summary()["faults_injected"] == 2


def test_dead_robot_stops_is_silent_stays_and_is_terminated():
    env = petswarm_env.parallel_env(**{**STILL, "faults": [{"at_s": 1.0, "robot": 3, "kind": "dead"}]})
    env.reset(seed=0)
    terminated = []
    for _ in range(15):
        _, _, term, _, _ = env.step({a: np.array([0.5, 0.0, 0.0], np.float32) for a in env.agents})
        terminated += [a for a, t in term.items() if t]
    assert terminated == ["robot_3"] and "robot_3" not in env.agents
    assert env.episode.fleet.nodes[3].state == "off"
    p = env.episode.world.robots[3].position
    _steps(env, 10)
    assert math.dist(p, env.episode.world.robots[3].position) < 0.05  # stopped, and stays (an obstacle)
    assert env.episode.world.robots[3].command == (0.0, 0.0, 0.0)


def test_transient_dead_fault_reboots_into_waiting():
    env = _env(faults=[{"at_s": 0.5, "robot": 2, "kind": "dead", "duration_s": 1.0}])
    _steps(env, 8)
    assert env.episode.fleet.nodes[2].state == "off"
    _steps(env, 10)
    assert env.episode.fleet.nodes[2].state in ("waiting", "slave")  # rebooted: waiting, maybe recruited again


def test_random_slave_and_random_faults_are_seeded():
    def log(seed):
        env = petswarm_env.parallel_env(**{**STILL, "faults_random.rate_per_min": 60.0, "faults_random.kinds": ["ir", "ahrs"],
                                           "faults": [{"at_s": 0.5, "robot": "random_slave", "kind": "ultrasonic"}]})
        env.reset(seed=seed)
        _steps(env, 80)
        return [(round(f.time_s, 6), f.robot, f.kind) for f in env.episode.runtime.faults.log]

    a, b = log(3), log(3)
    assert a == b and len(a) >= 2 and a[0][2] == "ultrasonic"
    assert {k for _, _, k in a[1:]} <= {"ir", "ahrs"}
