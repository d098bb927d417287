"""Sensor faults found by the robots themselves (middleware/diagnosis.py) and what follows: the status
lowers, the bid request (seed 003 Algorithm 2 step 5), the master's takeover; and IR readings credited
to the holder each receiver heard announced (middleware/fleet.py)."""

from __future__ import annotations

import math

import pytest

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.middleware import assignment
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.leaving import HANDOVER_BACK_MPS, HANDOVER_SIDE_MPS

FAULT_AT_S = 8.0


def _walk(kind: str, robot: int, seed: int = 0, at_s: float = FAULT_AT_S, **overrides):
    """A straight walk with the scripted reference; ``kind`` starts on ``robot`` at ``at_s``. Yields
    (env, observations) after every step."""
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "max_cycles": int(round((at_s + 14.0) / 0.1)),
                                       "faults": [{"at_s": at_s, "robot": robot, "kind": kind}], **overrides})
    obs, _ = env.reset(seed=seed)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    while env.agents:
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        yield env, obs


def test_an_ultrasonic_fault_is_found_by_the_robot_and_only_then_lowers_its_flags_and_status():
    frames = []
    seen = None
    for env, obs in _walk("ultrasonic", 3):
        if not frames:
            env.episode.radio.drop_filter = lambda f: frames.append((f.kind, f.src, f.dst)) or False
        node = env.episode.fleet.nodes[3]
        agent = "robot_3"
        if env.episode.runtime.faults.log and seen is None and agent in obs:
            pres = obs[agent][env.layout.slices["self.ultrasonic_present"]]
            # the robot stamps its detections on its own clock (seed 000 §3.3): the test reads true time
            found = [node.clock.true_time(t) for t, part in node.diagnosis.detected if part == "ultrasonic"]
            if not found:  # broken but not found yet: the robot believes its ring, and says so
                assert pres.min() == 1.0 and assignment.own_status(node).rate_sens_ma == 65.0
            else:
                seen = (found[0], pres.max(), assignment.own_status(node))
    assert seen is not None, "the ultrasonic fault was never detected"
    t, presence, status = seen
    assert 0 < t - env.episode.runtime.faults.log[0].time_s <= 1.0  # the ring's self-test: a few readings
    assert presence == 0.0  # the observation of the detection's own step reads the ring absent
    assert status.rate_sens_ma is None and "DISTANCE" not in status.sensors
    assert (msg.BID_REQUEST, 3, env.episode.fleet.nodes[0].node_id) in frames  # the bid request went to the master
    assert any(event == "lost" and 3 in ids for _, event, ids in env.episode.swarm.member_log)  # taken out of its slot
    assert env.episode.fleet.nodes[3].state == "waiting"


@pytest.mark.parametrize("kind", ["ir", "ahrs"])
def test_an_ir_or_ahrs_fault_is_found_within_3_s_and_the_robot_leaves_its_slot(kind):
    """Found within 3 s (the median of three seeds; one seed of 20 takes 3-4 s: an IR-blind slave
    searches, step 1d, and may leave the RSSI reach its check counts neighbours in)."""
    delays = []
    for seed in (0, 1, 2):
        for env, _ in _walk(kind, 2, seed=seed):
            pass
        node = env.episode.fleet.nodes[2]
        fault_s = env.episode.runtime.faults.log[0].time_s
        found = [node.clock.true_time(t) for t, part in node.diagnosis.detected if part == kind]  # logged on its own clock
        assert found and 0 < found[0] - fault_s <= 4.0
        delays.append(found[0] - fault_s)
        assert node.recovery.bid_requests and node.recovery.bid_requests[0][1] == kind
        assert 2 not in env.episode.swarm.master.know.members.values() and node.state == "waiting"
        # a robot that found a sensor broken declines the joining query under Table 2 (it is not recruited back)
        assert 2 not in env.episode.swarm.slave_ids()
    assert sorted(delays)[1] <= 3.0


def test_no_robot_finds_a_sensor_fault_that_is_not_there():
    """A radio fault (a member that falls silent and is declared lost) under loss is no sensor fault."""
    for env, _ in _walk("radio_silent", 1, seed=3, **{"radio.loss_prob": 0.2}):
        pass
    assert [d for n in env.episode.fleet.nodes.values() for d in n.diagnosis.detected] == []


_SLOT_OVER_S = 0.3  # longer than an IR slot (its token frame, the burst and the guard time)


def test_a_radio_silent_slave_credits_no_ir_reading_it_cannot_attribute():
    """A robot credits an IR reading to the holder its own ring frames announced: a radio-silent one hears
    no announcement and stores nothing, although its IR module sees every slot (once the slot it heard
    announced before the fault is over: ``_SLOT_OVER_S``)."""
    stored = None
    for env, _ in _walk("radio_silent", 2):
        log = env.episode.runtime.faults.log
        if log and stored is None and env.episode.world.now >= log[0].time_s + _SLOT_OVER_S:
            stored = {k: v.time_s for k, v in env.episode.fleet.nodes[2].know.ir.items()}
        if log and env.episode.world.now > log[0].time_s + 0.9:  # before its status timeout (1 s) makes it leave
            break
    assert stored is not None
    assert all(stored.get(k) == v.time_s for k, v in env.episode.fleet.nodes[2].know.ir.items())


@pytest.mark.parametrize("assignment", ["closest", "ruta_decentralized"])
def test_a_spare_takes_the_faulty_robots_slot_and_the_faulty_robot_is_not_recruited_back(assignment):
    """Seed 003 Algorithm 2 steps 5-7: after the bid request the slot is open, the refill recruits the
    fittest free robot (a spare switched on beside the swarm), never the robot that found its IR broken."""
    # the formation built and walking (as in the dropout scenario: the spare switched on 1 s before the fault)
    for env, _ in _walk("ir", 2, at_s=20.0, **{"swarm.assignment": assignment, "arrivals": [{"at_s": 19.0, "type": "petbot"}]}):
        pass
    log = [(event, ids) for _, event, ids in env.episode.swarm.member_log if event != "renumbered"]  # (building)
    spare = env.episode.runtime.arrived[0][1]
    assert log[:2] == [("lost", [2]), ("joined", [spare])]
    assert spare in env.episode.swarm.slave_ids() and 2 not in env.episode.swarm.slave_ids()


@pytest.mark.parametrize("kind", ["ahrs", "ultrasonic"])
def test_the_faulty_robot_drives_out_of_the_formation_and_the_rest_re_form(kind):
    """Seed 4 (the fault on robot 2, a front slave; seed 1's front slave, before the building's renumbering made
    it a rear one): a faulty robot that stopped where it stood was in the path of the member taking its place,
    which lagged 3.6 m behind 10 s later. Now it drives out beside the formation (its own wheels: the move needs
    no sensor), stops there, and the others re-form."""
    from petswarm.experiments import sensor_faults

    seen: dict = {}

    def watch(env):
        rec = env.episode.fleet.nodes[2].recovery
        if rec.clear_out is not None and "plan" not in seen:
            seen["plan"] = rec.clear_out
            seen["start"] = tuple(env.episode.world.robots[2].body.position)

    r = sensor_faults.run(kind, 4, on_step=watch)
    assert r["robot"] == 2 and r["detection_s"] is not None and r["detection_s"] <= 3.0
    assert "plan" in seen, "the faulty robot never planned its move out"
    _, _, vy, out_m = seen["plan"]
    assert abs(vy) > 0 and out_m >= 2 * 0.2  # sideways, at least its diameter
    assert r["reformed"], f"largest live-slave error {r['largest_error_m']:.2f} m 10 s after the detection"


@pytest.mark.parametrize("mode, seed, robot", [("following", 1, 2), ("leading", 101, 3)])
def test_the_faulty_robot_stops_once_it_is_out_on_its_own_clock(mode, seed, robot):
    """The move out runs on the robot's own MCU clock (seed 000 §3.3), which is offset from the world's by up
    to ``robot.clock_offset_max_s``: it ends once the wheels counted the sideways distance (or its time ran
    out), and the robot then stands. Before, the move read the world's time against its plan's local time:
    it never timed out and its first odometry step counted the clocks' offset, so the robot drove sideways
    for the rest of the episode (leading seed 101: 12 m, dragging the member that took its place along)."""
    from petswarm.experiments import sensor_faults
    from petswarm_env.middleware.leaving import CLEAR_SPEED_MPS, CLEAR_TIMEOUT

    seen: dict = {}

    def watch(env):
        ep = env.episode
        rec, body = ep.fleet.nodes[robot].recovery, ep.world.robots[robot].body
        if rec.clear_out is not None and "plan" not in seen:
            seen["plan"], seen["t0"] = rec.clear_out, ep.world.now
        elif "plan" in seen and rec.clear_out is None and "end" not in seen:
            seen["end"], seen["at"] = ep.world.now, tuple(body.position)
        elif "end" in seen and ep.world.now >= seen["end"] + 3.0 and "later" not in seen:
            seen["later"] = tuple(body.position)

    overrides = {} if mode == "following" else {"swarm.mode": mode}
    r = sensor_faults.run("ahrs", seed, overrides=overrides, on_step=watch)
    assert r["robot"] == robot and "plan" in seen
    out_m = seen["plan"][3]
    assert "end" in seen, "the faulty robot never ended its move out"
    assert seen["end"] - seen["t0"] <= CLEAR_TIMEOUT * out_m / CLEAR_SPEED_MPS + 0.2
    (x0, y0), (x1, y1) = seen["at"], seen["later"]
    assert ((x1 - x0) ** 2 + (y1 - y0) ** 2) ** 0.5 < 0.3, "the robot drove on after its move out ended"


def test_the_faulty_robot_keeps_the_swarms_pace_only_until_it_is_out_of_the_lanes():
    """Zigzag walk, seed 202 (204 before the heading exchange's one-round pairing, where a rear member renumbered to
    the front now sees no IR of its master for 4 s; 205 before the building's renumbering). The ultrasonic ring of
    robot 1, a front slave, breaks as the swarm nears a turn; the rear robot of its arm moves up, so it must drive
    out. A leaving robot that kept the swarm's
    pace for its whole move out held a fixed direction while the swarm turned: it cut across the formation
    and stopped beside it, where the formation ran onto it (seed 213, then the rear slave on the right:
    1.65 m 10 s after the detection; a rear slave now stops where it stands, the test below). Now it keeps
    the pace only until it is out of the formation's outermost lane by ``CLEAR_LANE_GAP_M``, then moves
    sideways standing along the walk, and the swarm walks past it."""
    import math

    from petswarm.experiments import sensor_faults

    seen: dict = {"pacing": [], "standing": []}

    def watch(env):
        ep = env.episode
        rec, body = ep.fleet.nodes[1].recovery, ep.world.robots[1].body
        if rec.clear_out is None:
            return
        seen.setdefault("plan", (rec.clear_out, rec.pace_until_m))
        done = rec._cleared[1]
        along = body.velocity.x * math.cos(body.angle) + body.velocity.y * math.sin(body.angle)  # its own x
        (seen["pacing"] if done < rec.pace_until_m - 0.1 else seen["standing"] if done > rec.pace_until_m + 0.1
         else []).append(along)

    r = sensor_faults.run("ultrasonic", 202, overrides={"user.scenario": "zigzag"}, on_step=watch)
    assert r["robot"] == 1 and "plan" in seen
    (_, vx, _, out_m), pace_until = seen["plan"]
    assert vx > 0.5 and 0 < pace_until < out_m  # the swarm's pace first, and then a part of the way standing
    assert max(seen["pacing"]) > 0.5, "it did not keep the swarm's pace while in the lanes"
    assert seen["standing"] and max(abs(v) for v in seen["standing"][3:]) < 0.15, "it kept driving ahead"
    assert r["reformed"], f"largest live-slave error {r['largest_error_m']:.2f} m 10 s after the detection"


@pytest.mark.parametrize("front", [True, False])
def test_a_leaving_robot_is_in_the_way_only_where_a_remaining_member_moves_or_walks(front):
    """1 + 4 wedge: a robot leaving a front slot of an arm stands in the lane of the rear robot of that arm,
    which moves up (it must drive out); one leaving a rear slot is in nobody's way (the others keep their
    slots or move ahead of it: it stops where it stands). Judged from the member update's tables only."""
    from petswarm_env.middleware.formation import formation_for_mode

    env = petswarm_env.parallel_env(**{"user.scenario": "straight"})
    env.reset(seed=0)
    ep = env.episode
    master = ep.fleet.nodes[ep.swarm.master.node_id]
    pos = master.formation.slot_positions()
    members = dict(master.know.members)
    leaving_member = max((m for m in members if m), key=lambda m: (-pos[m][0] if not front else pos[m][0]))
    leaving = members.pop(leaving_member)
    kept, formation, _ = master.recovery.removal_plan(
        members, formation_for_mode(ep.cfg.swarm, len(members), master.know.mode))
    assert ep.fleet.nodes[leaving].recovery.in_the_way(kept, formation, 1.0) is front


def test_a_robot_leaving_a_rear_slot_stops_and_the_swarm_turning_toward_it_walks_on():
    """Zigzag walk, seed 104 (the ultrasonic ring of robot 3, the rear slave on the right, breaks as the
    swarm nears a right turn). Moving out at the swarm's pace, it held a fixed direction while the swarm
    turned toward its side: it was carried ahead into the lane of the front robot on the right, which ran
    into it as it stood (largest live-slave error 2.0 m 10 s after the detection). In nobody's way, it now
    stops where it stands and the swarm walks on away from it."""
    from petswarm.experiments import sensor_faults

    seen: dict = {}

    def watch(env):
        rec = env.episode.fleet.nodes[3].recovery
        if rec.clear_out is not None and "plan" not in seen:
            seen["plan"] = rec.clear_out

    r = sensor_faults.run("ultrasonic", 104, overrides={"user.scenario": "zigzag"}, on_step=watch)
    assert r["robot"] == 3 and "plan" in seen
    _, vx, _, out_m = seen["plan"]
    assert vx == 0.0 and out_m == 0.0, "a robot in nobody's way drove out"
    assert r["reformed"], f"largest live-slave error {r['largest_error_m']:.2f} m 10 s after the detection"


def test_a_master_whose_ir_breaks_hands_its_user_over_by_table_3_and_the_swarm_goes_on():
    """The master finds its IR module broken (its slaves lose their fix of it): it hands the user over to
    the robot closest to the user by what it knows (Table 3, following: its last IR fixes, else the
    slots of its table), asks to leave as a slave (bid request), drives out of the
    way, and the new master follows the user to the end of the episode."""
    from petswarm.experiments import sensor_faults

    seen: dict = {}

    def watch(env):
        swarm = env.episode.swarms[0]
        if "members" not in seen and env.episode.runtime.faults.log:
            seen["members"] = dict(swarm.master.know.members)

    r = sensor_faults.run("ir", 2, target="master", on_step=watch)
    assert r["robot"] == 0 and r["detection_s"] is not None and r["detection_s"] <= 3.0
    assert len(r["handovers"]) == 1
    _, old, new, part = r["handovers"][0]
    assert (old, part) == (0, "ir") and new == r["master_after"]
    assert new in (seen["members"][1], seen["members"][2])  # one of the front pair, the closest to the user
    assert r["bid_request"] and r["other_detections"] == []  # the old master asked to leave its new slot
    assert r["session_state"] == "following" and r["user_distance_end_m"] <= sensor_faults.USER_FOLLOWED_M
    assert r["reformed"]


@pytest.mark.parametrize("mode, seed", [("following", 718), ("leading", 2)])
def test_the_old_master_moves_out_sideways_at_the_wheels_top_speed_and_is_left_behind(mode, seed):
    """Zigzag walk, seed 718 (the master's IR breaks; the user stops at the alert for about half a second). The
    old master, a slave now, kept its own pace while it moved out at 0.5 m/s: carried 3 m along beside the swarm's
    front for 4.5 s, it stopped where the next turn brought the swarm onto it, and the rear slave on that side
    stood behind it (1.12 m off 10 s after the detection). Now it moves out sideways at the wheels' top speed, and
    back against the walk once clear of the lanes, and is left behind the swarm. A leading swarm's old master (its
    user stands until the new master is in place; the swarm walks the way its back faces) moves out at that speed
    across the walk it told the new master, keeping no pace, so the swarm it led walks past it."""
    from petswarm.experiments import sensor_faults

    seen: dict = {}

    def watch(env):
        rec = env.episode.fleet.nodes[0].recovery
        if rec.clear_out is not None and "plan" not in seen:
            seen["plan"], seen["told"] = rec.clear_out, env.episode.fleet.nodes[0].modes.walk_told

    overrides = {"user.scenario": "zigzag"} if mode == "following" else {"swarm.mode": mode}
    r = sensor_faults.run("ir", seed, target="master", overrides=overrides, on_step=watch)
    assert r["robot"] == 0 and r["master_after"] != 0 and "plan" in seen
    _, vx, vy, out_m = seen["plan"]
    if mode == "following":
        assert (vx, abs(vy)) == (-HANDOVER_BACK_MPS, HANDOVER_SIDE_MPS) and out_m > 1.0
        assert r["reformed"], f"largest live-slave error {r['largest_error_m']:.2f} m 10 s after the detection"
        assert r["session_state"] == "following" and r["user_distance_end_m"] <= sensor_faults.USER_FOLLOWED_M
    else:
        assert math.hypot(vx, vy) == pytest.approx(HANDOVER_SIDE_MPS) and out_m > 1.0
        walk = seen["told"][0]  # the walk it told, its body frame then (it turned a little since: its AHRS carries it)
        assert abs(vx * math.cos(walk) + vy * math.sin(walk)) < 0.1 * HANDOVER_SIDE_MPS  # across the walk
        assert r["session_state"] == "leading" and r["user_distance_end_m"] <= sensor_faults.USER_FOLLOWED_M


def test_the_old_master_of_a_wedge_backs_off_only_once_clear_of_its_lanes():
    """1 + 8 wedge, straight walk, seed 7004 (the master's IR breaks; the front-left slave takes over). Backing off
    from the start (sideways 1.0 m/s and back 0.5 m/s against a walk of 1 m/s), the old master crossed the wedge's
    right arm, whose robots stand 30° off the back axis, and ran into the rear corner slave on its way to its new
    slot: shoved back 1 m, at top speed it closed 0.2-0.4 m/s on the walking swarm, 1.01 m off 10 s after the
    detection. Now it drives no speed along the walk until its wheels count it clear of the outermost lane, then
    backs off: the swarm re-forms."""
    from petswarm.experiments import sensor_faults

    seen: dict = {"clearing": [], "backing": []}

    def watch(env):
        rec, robot = env.episode.fleet.nodes[0].recovery, env.episode.world.robots[0]
        if rec.clear_out is None:
            return
        seen.setdefault("plan", (rec.clear_out, rec.pace_until_m, rec.back_after_m))
        done, body = rec._cleared[1], robot.body
        along = body.velocity.x * math.cos(body.angle) + body.velocity.y * math.sin(body.angle)  # its own x
        back_after = rec.back_after_m
        phase = seen["clearing"] if done < back_after - 0.2 else seen["backing"] if done > back_after + 0.2 else []
        phase.append((robot.command[0], along))  # (commanded, true) speed along its own x

    r = sensor_faults.run("ir", 7004, target="master", overrides={"swarm.num_slaves": 8}, on_step=watch)
    assert r["robot"] == 0 and r["master_after"] != 0 and "plan" in seen
    (_, vx, vy, out_m), pace_until, back_after = seen["plan"]
    assert (vx, abs(vy)) == (-HANDOVER_BACK_MPS, HANDOVER_SIDE_MPS) and pace_until == 0.0 and 1.0 < back_after < out_m
    assert seen["clearing"] and seen["backing"]
    # no speed along the walk commanded while in the lanes (the step it started on still carries its walking command),
    # and its wheels brake from its walking pace to under 0.2 m/s within a second
    assert all(cmd == 0.0 for cmd, _ in seen["clearing"][1:]) and max(abs(v) for _, v in seen["clearing"][10:]) < 0.2
    assert min(v for _, v in seen["backing"][3:]) < -0.3  # backing off beyond them
    assert r["reformed"], f"largest live-slave error {r['largest_error_m']:.2f} m 10 s after the detection"


def test_a_handovers_plan_places_the_members_it_does_not_see_in_its_own_frame():
    """1 + 8, straight walk, seed 7094 (the master's IR breaks; a front slave takes over). Its own frame lay 31° round
    from its table's when it planned the members on the slots about the old master's place: a rear member it had no
    fix of was costed at its slot of the table, 1.0 m from where it stood, and the plan sent another member 0.95 m to
    the slot beside that member; held by a neighbour's keep-out, the other fell behind the walk (0.86 m off 10 s after
    the detection). Now the table's frame is fitted onto the master's fixes
    first (``RecoveryManager._slots_onto_fixes``), and the swarm re-forms."""
    from petswarm.experiments import sensor_faults

    r = sensor_faults.run("ir", 7094, target="master", overrides={"swarm.num_slaves": 8})
    assert r["robot"] == 0 and r["master_after"] != 0 and len(r["handovers"]) == 1
    # within 0.5 m 10 s after the detection (0.86 m before; the re-formed mark, 0.3 m, is met or missed by a few
    # centimetres on this seed as the ring's timing moves the trajectory: 0.31 m after the one-round pairing)
    assert r["largest_error_m"] <= 0.5, f"largest live-slave error {r['largest_error_m']:.2f} m 10 s after the detection"


def test_a_new_following_master_starts_from_the_old_masters_heading_as_its_users_walk():
    """Zigzag walk, seed 217 (the master's IR breaks; a front slave takes over). The new master's controller
    guessed that its user walks away along its line of sight (from a front slot, half a spacing beside the old
    master) and its LF track pulled that round slowly: it trailed its user 1.7-2.3 m and lost them (emergency
    at the end). Now it starts from its own estimate of the old master's heading (seed 002 §3.3: the following
    master faces the way its user walks, ``succession.walk_direction``), and drives its user to the end."""
    import petswarm_env.middleware.user_session as us
    from petswarm.experiments import sensor_faults

    estimates: list = []
    seen: dict = {}

    def watch(env):
        if estimates and "psi" not in seen:  # the step of the new master's start
            seen["psi"] = env.episode.sessions[0].ctrl.walk_direction_rad

    real = us.walk_direction
    us.walk_direction = lambda *args: estimates.append(real(*args)) or estimates[-1]
    try:
        r = sensor_faults.run("ir", 217, target="master", overrides={"user.scenario": "zigzag"}, on_step=watch)
    finally:
        us.walk_direction = real
    assert r["master_after"] != 0 and len(estimates) == 1
    assert seen["psi"] == pytest.approx(estimates[0], abs=0.05)
    assert r["session_state"] == "following" and r["user_distance_end_m"] <= sensor_faults.USER_FOLLOWED_M


def test_a_leading_master_that_hands_over_mid_turn_tells_the_new_master_the_way_its_user_walks():
    """Leading zigzag walk, seed 304: the master's IR breaks just after a turn, its back still 50° off the way its
    user walks (its controller's ψ 2.25 rad, not π). The new master took the walk from the old master's back: up to
    80° off, it drove off its user's line and lost them (emergency at the end). Now the handover frame carries the
    old master's ψ (2 bytes more, ``messages.WALK_BYTES``), and the new master takes it when it is over
    ``TOLD_WALK_OFF_DEG`` off the old master's back (``succession.walk_direction``): it drives its user to the end."""
    from petswarm.experiments import sensor_faults
    from petswarm_env.middleware.succession import TOLD_WALK_OFF_DEG

    told: dict = {}

    def watch(env):
        for i, n in env.episode.fleet.nodes.items():
            if n.modes.told_walk_rad is not None:
                told.setdefault(i, n.modes.told_walk_rad)

    r = sensor_faults.run("ir", 304, target="master", overrides={"user.scenario": "zigzag", "swarm.mode": "leading"},
                          on_step=watch)
    assert list(told) == [r["master_after"]] and r["master_after"] != 0  # told to the new master only
    assert abs(math.remainder(told[r["master_after"]] - math.pi, 2 * math.pi)) > math.radians(TOLD_WALK_OFF_DEG)
    assert r["session_state"] == "leading" and r["user_distance_end_m"] <= sensor_faults.USER_FOLLOWED_M
    assert msg.payload_bytes(msg.HANDOVER, {"walk_rad": 0.1}) == msg.payload_bytes(msg.HANDOVER, {}) + msg.WALK_BYTES


@pytest.mark.parametrize("kind", ["ultrasonic", "ahrs"])
def test_a_master_whose_ultrasonic_or_ahrs_breaks_finds_it_and_keeps_its_user(kind):
    """The master's ultrasonic ring or AHRS: found by its own diagnosis like a slave's, and the master keeps its
    role (its LF antennas locate the user, its IR is seen by the slaves: docs/faults.md, measured against a
    handover): no handover, no bid request, the formation holds and the user is driven to the end."""
    from petswarm.experiments import sensor_faults

    r = sensor_faults.run(kind, 2, target="master")
    assert r["robot"] == 0 and r["detection_s"] is not None and r["detection_s"] <= 3.0
    assert r["handovers"] == [] and r["master_after"] == 0 and not r["bid_request"] and r["other_detections"] == []
    assert r["session_state"] == "following" and r["user_distance_end_m"] <= sensor_faults.USER_FOLLOWED_M
    assert r["reformed"]


def test_a_master_whose_ahrs_breaks_tracks_its_user_by_its_wheels_through_the_turns():
    """A master's AHRS freezes on a zigzag walk (seed 101): once its own diagnosis found it broken, its user
    tracker turns its odometry frame by the wheel odometry's ω (``UserTracker.move_without_ahrs``). Before,
    the frozen reading left the frame unturned at every turn of the walk; the track put the user 17 m off
    (95th percentile) and the master lost its user (emergency, 10.7 m away at the end)."""
    from petswarm.experiments import sensor_faults

    off: list[float] = []

    def watch(env):
        ep = env.episode
        session = ep.sessions[0]
        node = session.tracker_node
        est = session.tracker.user_body(node.clock.now)
        if est is None or "ahrs" not in node.diagnosis.failed:
            return
        robot, user = ep.world.robots[node.node_id], ep.world.users[0]
        dx, dy = user.body.position[0] - robot.position[0], user.body.position[1] - robot.position[1]
        c, s = math.cos(robot.heading), math.sin(robot.heading)
        off.append(math.hypot(est[0][0] - (c * dx + s * dy), est[0][1] - (-s * dx + c * dy)))

    r = sensor_faults.run("ahrs", 101, target="master", overrides={"user.scenario": "zigzag"}, on_step=watch)
    assert r["handovers"] == [] and len(off) > 100
    assert max(off) < 1.0, f"the master's track put its user {max(off):.1f} m off"
    assert r["session_state"] == "following" and r["user_distance_end_m"] <= sensor_faults.USER_FOLLOWED_M


@pytest.mark.parametrize("seed", [113, 118])
def test_a_leading_master_hands_its_user_to_the_robot_farthest_ahead_along_the_walk(seed):
    """Leading, the master's IR breaks: Table 3's "highest hierarchical level" is read along the leading layout
    (seed 000 Fig. 10: the levels run from the user forward), the robot farthest ahead of the user along the walk
    by the master's own view (``modes.SwarmGeometry.ahead_of_user``). By distance alone the farthest robot was one
    beside the user (seeds 113 and 118: 85° and 82° from the walk), which had to swing round its user to its place
    ahead while its slaves re-formed on it: 4.7 m and 1.0 m off 10 s after the detection."""
    from petswarm.experiments import sensor_faults

    seen: dict[str, float] = {}

    def watch(env):
        ep = env.episode
        swarm, user = ep.swarms[0], ep.world.users[0]
        if swarm.fault_handovers and "angle" not in seen:
            robot = ep.world.robots[swarm.fault_handovers[0][2]]
            bearing = math.atan2(robot.position[1] - user.body.position[1], robot.position[0] - user.body.position[0])
            seen["angle"] = abs(math.degrees(math.remainder(bearing - user.heading, 2.0 * math.pi)))

    r = sensor_faults.run("ir", seed, target="master", overrides={"swarm.mode": "leading"}, on_step=watch)
    # (60°: seed 113's new master stood 45.2° off with the scripted reference's step 1d search, 50.3° since its slaves
    # keep 1.0 m off a leading user walking straight on; by distance 82-85°)
    assert r["master_after"] != 0 and seen["angle"] < 60.0, f"the new master stood {seen['angle']:.0f}° from the walk"
    # (by distance 4.7 and 1.0 m off; since the old leading master moves straight out sideways, 0.40 and 0.35 m:
    # seeds 113 and 118 miss the 0.3 m of "re-formed" there, as 2 and 4 of seeds 100-119 and 200-239 do)
    assert r["largest_error_m"] < 0.5 and r["session_state"] == "leading"


@pytest.mark.parametrize("seed", [104, 114])
def test_after_a_handover_the_new_masters_tracker_takes_only_its_own_lf_fixes(seed):
    """An LF fix is stamped on the clock of the robot that burst it (seed 000 §3.3: each robot its own
    clock) and taken only by that robot's tracker; the first one replaces the new master's own guess of its
    user. Before, a burst of the handover's takeover was stamped on the old master's clock and taken by the
    new master's tracker (seed 104: a user velocity of thousands of m/s), and the first fix was blended with
    the guess (seed 114: a sideways velocity that took the new master off its user's line): in both the new
    master lost its user (emergency, 20-23 m behind at the end)."""
    from petswarm.experiments import sensor_faults

    fastest: list[float] = []

    def watch(env):
        session = env.episode.sessions[0]
        if session.tracker_node.node_id != 0 and session.tracker.pos is not None:
            fastest.append(max(abs(v) for v in session.tracker.vel))

    r = sensor_faults.run("ir", seed, target="master", on_step=watch)
    assert r["master_after"] != 0 and fastest
    assert max(fastest) < 5.0, f"the new master's tracker put its user at {max(fastest):.0f} m/s"
    assert r["session_state"] == "following" and r["user_distance_end_m"] <= 2.0


@pytest.mark.parametrize("seed, loss", [(19, 0.0), (7, 0.3)])
def test_a_new_master_searching_among_bodies_keeps_its_ir_and_a_dead_robot_diagnoses_nothing(seed, loss):
    """Leading, the master dies at 20 s: the new master searches for its user among its swarm, the user and
    the dead robot, which hide the ring's holders from its IR for a second or two. Five misses from three
    holders within 0.8-1.1 s found its working IR module broken (seed 19 at loss 0, seed 7 at loss 0.3) and
    it handed the role on; a streak must now span diagnosis.IR_MISS_SPAN_S. A robot that is off runs no
    diagnosis (before: the dead master's unchanging AHRS readings were found frozen)."""
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "max_cycles": 500, "swarm.mode": "leading",
                                       "radio.loss_prob": loss, "faults": [{"at_s": 20.0, "robot": "master", "kind": "dead"}]})
    obs, _ = env.reset(seed=seed)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    while env.agents:
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.active_agents}))
    ep = env.episode
    found = [(i, part) for i, n in ep.fleet.nodes.items() for _, part in n.diagnosis.detected]
    assert found == [], f"found broken, with no sensor fault: {found}"
    assert ep.swarms[0].fault_handovers == []


@pytest.mark.parametrize("seed", [14, 58, 94, 50])
def test_a_column_robot_whose_only_near_neighbours_ir_breaks_keeps_its_own_module_and_role(seed):
    """Column: the IR module of the master's one neighbour within IR_EXPECT_RANGE_M breaks (seeds 14, 58, 94). The
    master's own slot and that member's slot give no fix or report: two holders, the faulty member's own evidence
    too. Seed 14: the member's bid request (it lists the sensors that work) came first and starts the master's streak
    over; seeds 58 and 94: the master's streak was complete first and it handed its user to the faulty member — two
    holders now need diagnosis.IR_PAIR_SPAN_S. Seed 50: the tail's front neighbour breaks and is removed; the tail's
    streak went on with the slots of its new front neighbour, still driving up, and found its module broken; a
    holder that left the member table ends the streak."""
    from petswarm.experiments import sensor_faults

    r = sensor_faults.run("ir", seed, overrides={"swarm.formation": "column"})
    assert r["detection_s"] is not None and r["bid_request"]
    assert r["other_detections"] == [] and r["handovers"] == [], (r["other_detections"], r["handovers"])
    assert r["reformed"], f"largest live-slave error {r['largest_error_m']:.2f} m 10 s after the detection"


@pytest.mark.parametrize("seed", [5072, 8070])
def test_a_master_whose_swarm_drifted_beyond_its_near_irs_range_still_finds_its_ir_broken(seed):
    """Loss 0.3, the master's IR broken at 20 s: its slaves lose its fixes and fall back, and within seconds
    every holder it hears announced stands beyond diagnosis.IR_EXPECT_RANGE_M by RSSI (1.7-3 m), so the near
    rule counts no miss and it never found the fault. The far rule (IR_FAR_EXPECT_M, IR_FAR_SPAN_S) finds it,
    and it hands its user over."""
    from petswarm.experiments import sensor_faults

    r = sensor_faults.run("ir", seed, target="master", overrides={"radio.loss_prob": 0.3})
    assert r["detection_s"] is not None and r["handovers"], r
    assert r["other_detections"] == []


@pytest.mark.parametrize("seed, overrides", [(5024, {"radio.loss_prob": 0.3}),
                                             (6036, {"radio.loss_prob": 0.1, "swarm.num_slaves": 8})])
def test_a_slave_in_its_users_ir_shadow_keeps_its_working_module(seed, overrides):
    """No fault: a slave stands 0.5-1.2 m beyond its user from its master, which with the master's near members hides
    them from its IR for over 4 s while their start signs arrive from 1.6-2.2 m. The far rule is the master's alone
    and wants three holders: with two (seed 5024) or for a slave (seed 6036) it found this healthy module broken."""
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "max_cycles": 260, **overrides})
    obs, _ = env.reset(seed=seed)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    while env.agents:
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.active_agents}))
    found = [(i, part) for i, n in env.episode.fleet.nodes.items() for _, part in n.diagnosis.detected]
    assert found == [], f"found broken, with no sensor fault: {found}"

@pytest.mark.parametrize("seed", [1300, 1302])
def test_a_large_wedge_re_forms_after_its_masters_ir_fault_from_the_new_masters_place(seed):
    """1 + 8, the master's IR broken at 20 s: the new master keeps the table it took (no re-plan after its
    ring's first round, which planned from beside its old slot) and plans the old master's removal from
    the old master's place, where it drives (before: a rear member crossed the wedge, fell 3 m behind
    its slot and out of its reference's IR reach)."""
    from petswarm.experiments.sensor_faults import run as measure

    r = measure("ir", seed, target="master", overrides={"swarm.num_slaves": 8})
    assert r["handovers"] and r["detection_s"] is not None and r["detection_s"] <= 3.0
    assert r["largest_error_m"] <= 0.5, r["largest_error_m"]  # 3 m before; the 0.3 m mark met by a few cm or missed (1302: 0.30)


def test_a_new_master_drives_its_user_on_its_own_track_from_the_moment_it_takes_them_over():
    """1 + 8, the master's IR broken at 20 s, seed 5006: the new master drives its user (the session commands
    ``swarm.master``) from the moment it takes the handover. Before, its session switched only when the old master
    had waited out its handover's acknowledgement: for two control periods the new master was driven on the old
    master's user track, in the old master's frame, turned 40° away from its user, and the formation, which
    turns with it, was still 0.9 m off 10 s after the detection."""
    from petswarm.experiments.sensor_faults import run as measure

    on_other: list[tuple[float, int, int]] = []

    def watch(env):
        session, swarm = env.episode.sessions[0], env.episode.swarms[0]
        if session.connected_robot is not None and session.tracker_node is not swarm.master:
            on_other.append((env.episode.world.now, session.tracker_node.node_id, swarm.master.node_id))

    r = measure("ir", 5006, target="master", overrides={"swarm.num_slaves": 8}, on_step=watch)
    assert r["handovers"] and r["master_after"] != 0
    assert on_other == [], f"(time, tracker's robot, commanded master): {on_other}"
    # 0.9 m off at the mark before; re-formed at the mark (0.3 m) until the master broadcast its commanded speed, 0.60 m
    # on this code (0.43 m 2 s later): the mark depends on the seed's trajectory, the old fault's 0.9 m does not come back
    assert r["largest_error_m"] <= 0.7, r["largest_error_m"]
