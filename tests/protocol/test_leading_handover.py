"""A leading master's successor after a handover for a broken part (seed 000 Table 3, leading: the highest
level) starts from its own knowledge of the way its user walks (seed 002 §3.4: the leading master drives
backwards along it, facing its user), swings in ahead of its user while the user stands at the belt's alert,
and the user walks on only once it stands there."""

from __future__ import annotations

import math

import pytest

from petswarm_env.config import load_config
from petswarm_env.control.master import BeltView, MasterController
from petswarm_env.sim.geometry import wrap_angle
from tests.unit.test_master import _Robot

CFG = load_config()


def _swing_in(know: bool) -> tuple[float, float]:
    """A new leading master 1.3 m beside its standing user (70° round from straight ahead), facing along the
    walk as its old master did; the belt still reports the walk (its activity window lags the stop). Returns
    (its place about the user from straight ahead, its heading off the walk's reverse), degrees, after 4 s."""
    ctrl = MasterController(CFG.master, math.radians(CFG.lf.reliable_half_angle_deg))
    walk = 0.0  # the user walks along +x (world) and stands now
    user = (0.0, 0.0)
    place = math.radians(70.0)
    robot = _Robot((1.3 * math.cos(place), 1.3 * math.sin(place)), math.pi)
    if know:
        ctrl.know_walk_direction(walk - robot.th)  # what its own estimate of its old master's heading gives
    belt = BeltView("walk", False, 0.0, 0.0)
    for _ in range(40):
        cmd = ctrl.command(tuple(robot.to_body(user)), (0.0, 0.0), belt, robot.body_velocity(), "leading", 1.6, 0.1)
        robot.step(cmd, 0.1)
    off = wrap_angle(math.atan2(robot.pos[1] - user[1], robot.pos[0] - user[0]) - walk)
    return math.degrees(off), math.degrees(wrap_angle(robot.th - (walk + math.pi)))


def test_a_new_leading_master_that_knows_the_walk_swings_in_ahead_of_its_user():
    off, heading = _swing_in(know=True)
    assert abs(off) < 20.0 and abs(heading) < 20.0, (off, heading)
    off_guess, heading_guess = _swing_in(know=False)  # the first command's guess: the user faces the robot
    assert abs(off_guess) > 45.0 or abs(heading_guess) > 45.0, (off_guess, heading_guess)


@pytest.mark.parametrize("seed", [200, 203])
def test_after_a_leading_masters_ir_fault_the_user_walks_on_only_with_the_new_master_ahead(seed):
    """Seed 200 (and 201, before the IR fixes were carried over each slave's own odometry): the new master
    once guessed that its user faced it, turned 50-80° off the walk, the user walked on at once, and, facing
    its user diagonally, the robot's mecanum wheels barely out-paced them: its slaves were 0.82 / 0.98 m off
    10 s after the detection. Seed 201's episode differs since the carried fixes: its new master is ahead
    (21°) but one slave's error swings 0.1-0.5 m while the swarm walks, before the fault as after, and stood
    at 0.52 m at the 10-s mark; seed 203 is the next seed whose user stands at the alert and whose swarm
    re-formed both before and after that change (seeds 200-239 re-form 32 -> 38 of 40 with it)."""
    from petswarm.experiments import sensor_faults

    seen: dict = {"resumed": None}

    def watch(env):
        ep = env.episode
        session, user = ep.sessions[0], ep.world.users[0]
        if session.alert_pause_s is not None:
            seen["paused"] = True
        elif seen.get("paused") and seen["resumed"] is None and user.walking:
            robot = ep.world.robots[session.swarm.master.node_id].body
            dx, dy = robot.position[0] - user.body.position[0], robot.position[1] - user.body.position[1]
            seen["resumed"] = math.degrees(wrap_angle(math.atan2(dy, dx) - user.heading))

    r = sensor_faults.run("ir", seed, target="master", overrides={"swarm.mode": "leading"}, on_step=watch)
    assert r["master_after"] != 0 and r["session_state"] == "leading"
    assert seen.get("paused") and seen["resumed"] is not None
    assert abs(seen["resumed"]) < 35.0, f"the user walked on with the new master {seen['resumed']:.0f}° off straight ahead"
    assert r["reformed"], f"largest live-slave error {r['largest_error_m']:.2f} m 10 s after the detection"


def test_the_new_masters_ring_counts_no_round_it_did_not_run():
    """Leading, IR fault on the master, seed 215: the robot that takes the role over holds the token of
    its own slot as it does (a slave's slot). That slot's end is no round of its ring as master (it
    restarted the ring, token_ring.start_as_master): counted as one, every member it had not heard
    since was one round silent, and the new slot's count made it two — a live slave was declared lost
    and left the swarm with the faulty old master (before: re-formed only after a refill, 1.6 m off
    10 s after the detection). Only the old master, which asked to leave, is removed."""
    from petswarm.experiments import sensor_faults

    holder = {}
    row = sensor_faults.run("ir", 215, 20.0, "master", {"swarm.mode": "leading"},
                            on_step=lambda env: holder.setdefault("env", env))
    swarm = holder["env"].episode.swarms[0]
    (_, old, new, _), = swarm.fault_handovers
    lost = [n for _, event, ids in swarm.member_log if event == "lost" for n in ids]
    assert lost == [old], (swarm.member_log, old, new)
    assert row["largest_error_m"] <= 0.5, row  # 1.6 m before; the 0.3 m mark met by a few cm or missed (0.31 m now)
