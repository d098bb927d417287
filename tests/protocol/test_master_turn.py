"""A slave's estimate of its master's heading is carried over the master's turn since the heading exchange, by the
turn rates of the master's status broadcasts (seed 000 §3.5: (vx, vy, ω)); middleware/succession.py."""

from __future__ import annotations

import math
from collections import deque

import pytest

from petswarm_env.middleware.succession import MASTER_TURN_HISTORY, SuccessionManager, master_heading_offset
from petswarm_env.sim.geometry import wrap_angle


def _turns() -> SuccessionManager:
    """The turn record of a succession manager, without a robot (the record reads none)."""
    sm = SuccessionManager.__new__(SuccessionManager)
    sm._turns, sm._turn_src = deque(maxlen=MASTER_TURN_HISTORY), None
    return sm


def test_the_masters_turn_is_the_integral_of_its_broadcast_turn_rates():
    sm = _turns()
    for k in range(21):  # 0.5 rad/s for 1 s, then 0 for 1 s
        sm.heard_status(7, 10.0 + 0.1 * k, 0.5 if k < 10 else 0.0)
    assert sm.master_turned(7, 10.0) == pytest.approx(0.5 * 0.9 + 0.25 * 0.1)  # the last step's rates averaged
    assert sm.master_turned(7, 10.45) == pytest.approx(0.5 * 0.45 + 0.25 * 0.1)  # from within a broadcast's period
    assert sm.master_turned(7, 11.5) == 0.0
    assert sm.master_turned(3, 10.0) == 0.0  # another robot's: none heard
    assert sm.master_turned(7, 9.0) == 0.0  # before the first broadcast heard: unknown
    sm.heard_status(3, 12.1, 1.0)  # a new master: its own count
    assert sm.master_turned(7, 10.0) == 0.0 and sm.master_turned(3, 12.1) == 0.0


def test_a_handovers_new_master_knows_its_old_masters_heading_after_a_u_turn():
    """u_turn, IR on the master at 20 s (seed 18): the user turns about while the old master's IR is broken; the
    slaves' heading exchanges with it stopped with the fault. Taken from before the fault, the new master's estimate
    of the old master's heading was 73° off at the handover and it put its user 2.6 m off, on the wrong side (the
    user stood at the belt's alert until the first LF fix, a mirrored one; then walked off: emergency)."""
    from petswarm.experiments import sensor_faults

    seen = []

    def watch(env):
        sw = env.episode.swarms[0]
        if sw.handing_over and not seen:
            old, new = sw.master, env.episode.fleet.nodes[sw.fault_handovers[-1][2]]
            robots = env.episode.world.robots
            truth = wrap_angle(robots[old.node_id].heading - robots[new.node_id].heading)
            seen.append(abs(wrap_angle(master_heading_offset(new, old.node_id) - truth)))

    r = sensor_faults.run("ir", 18, target="master", overrides={"user.scenario": "u_turn"}, on_step=watch)
    assert seen and seen[0] < math.radians(15.0), f"the new master's heading estimate {math.degrees(seen[0]):.0f}° off"
    assert r["reformed"] and r["session_state"] == "following", r
