"""Robot types (seeds 001 and 003): the robot_types config, swarm.pool, the bodies (differential drive,
wheel slip, per-type limits, the battery) and seed 001's middle layer on them (mapping tables,
NULL location, presence 0, the behaviour refusal)."""

import math

import numpy as np
import pymunk
import pytest

from petswarm_env.config import ConfigError, load_config
from petswarm_env.mapping import Behaviour, BehaviourRefused
from petswarm_env.middle_layer import MiddleLayer, attach_check, behaviour_table, build_body_map
from petswarm_env.robot_types import DEFAULT_TYPE, pool_types, resolve, virtual_ring
from petswarm_env.sim.battery import Battery
from petswarm_env.sim.robot import Robot

CFG = load_config()


def _robot(name: str, cfg=CFG) -> Robot:
    space = pymunk.Space()
    return Robot(0, cfg.robot, space, (0.0, 0.0), 0.0, resolve(cfg, name)), space


def _drive(robot, space, seconds: float, dt: float = 0.02):
    for _ in range(round(seconds / dt)):
        robot.apply(dt)
        space.step(dt)


# -- config --------------------------------------------------------------------------------------

def test_the_shipped_types_and_the_default_pool():
    assert set(CFG.robot_types) >= {"petbot", "mybot", "r1", "r2"}
    assert CFG.swarm.pool == []
    assert pool_types(CFG) == [DEFAULT_TYPE] * (CFG.swarm.num_slaves + CFG.swarm.extra_robots)
    pet = resolve(CFG, DEFAULT_TYPE)
    assert pet.robot is CFG.robot and pet.drive == "mecanum" and pet.slip == 0.0 and pet.can_be_master
    # the petbot's DISTANCE sensors are the virtual ring itself: its table is the identity
    assert build_body_map(pet, virtual_ring(CFG.robot.ultrasonic.count, CFG.robot.radius_m)).identity


def test_mybot_is_seed_001_table_iii_and_inherits_what_it_does_not_list():
    mybot = resolve(CFG, "mybot")
    assert mybot.drive == "differential"
    ds = mybot.distance_sensors
    assert len(ds) == 6 and {s.location.radius_m for s in ds} == {0.15}
    # Table III's 180, 135, 90, 45, 0, 270 (90 = front) in the ring frame (0 = forward)
    assert [s.location.angle_deg for s in ds] == [(a - 90) % 360 for a in (180, 135, 90, 45, 0, 270)]
    assert mybot.battery.sensing_ma == resolve(CFG, "petbot").battery.sensing_ma  # not listed: the petbot's
    assert mybot.robot.ahrs_noise_deg == CFG.robot.ahrs_noise_deg
    assert not mybot.can_be_master
    r1, r2 = resolve(CFG, "r1"), resolve(CFG, "r2")
    assert r1.slip == pytest.approx(0.03) and r1.battery.servo_ma == 130.0  # seed 003 §5.2.1
    assert r2.slip == pytest.approx(0.01) and r2.battery.servo_ma == 320.0
    assert r1.robot.max_speed_mps < CFG.robot.max_speed_mps < r2.robot.max_speed_mps


def test_a_pool_expands_in_order():
    cfg = load_config(overrides={"swarm.pool": [{"type": "mybot", "count": 2}, {"type": "r2", "count": 3}]})
    assert pool_types(cfg) == ["mybot", "mybot", "r2", "r2", "r2"]


@pytest.mark.parametrize("overrides, message", [
    ({"swarm.pool": [{"type": "tank", "count": 4}]}, "swarm.pool[0].type 'tank' is not a robot type; robot_types defines: mybot, petbot, r1, r2"),
    ({"swarm.pool": [{"type": "mybot", "count": 2}]}, "holds 2 robots; it needs at least swarm.num_slaves=4"),
    ({"swarm.pool": [{"type": "mybot", "count": 0}]}, "swarm.pool.0.count"),
    ({"swarm.pool": [{"type": "mybot", "count": 4}], "swarm.extra_robots": 1}, "swarm.extra_robots must be 0 with a swarm.pool"),
    ({"robot_types.petbot.battery_mah": None}, "robot_types.petbot must give every key"),
    ({"robot_types.petbot.radius_m": 0.3}, "is set in robot: (robot.radius_m)"),
    ({"robot_types.mybot.behaviours": ["MOVE"]}, "MOVE comes with the drive"),
    ({"robot_types.mybot.drive": "tracks"}, "robot_types.mybot.drive"),
    ({"robot_types.r1.wheel_slip_pct": 100}, "robot_types.r1.wheel_slip_pct"),
    ({"robot_types.r1.colour": "red"}, "unknown config key 'robot_types.r1.colour'"),
])
def test_bad_types_and_pools_are_refused_in_one_line(overrides, message):
    with pytest.raises(ConfigError) as err:
        load_config(overrides=overrides)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_a_user_may_add_a_type():
    cfg = load_config(overrides={"robot_types.tank": {"drive": "differential", "max_speed_mps": 0.5},
                                 "swarm.pool": [{"type": "tank", "count": 4}]})
    tank = resolve(cfg, "tank")
    assert tank.robot.max_speed_mps == 0.5 and tank.sensors == resolve(cfg, "petbot").sensors


# -- bodies ----------------------------------------------------------------------------------------

def test_a_differential_body_has_no_vy_and_turns_toward_the_commanded_direction():
    robot, space = _robot("mybot")
    spec = robot.spec
    robot.set_command(0.5, 0.3, 0.0)
    vx, vy, w = robot.command
    assert vy == 0.0 and vx == pytest.approx(0.5) and w == pytest.approx(0.3 / spec.lookahead_m)
    _drive(robot, space, 1.0)
    assert robot.heading > 0.2  # turned left, toward +y
    bvx, bvy, _ = robot.velocity_body
    assert abs(bvy) < 0.05 * abs(bvx)  # no sideways motion of its own
    assert behaviour_table(spec) == [{"virtual": "MOVE", "physical": "MOVE", "missing_fields": ["vy"]}]


def test_per_type_limits_saturate_the_move():
    robot, _ = _robot("r1")
    robot.set_command(5.0, 0.0, 0.0)
    assert robot.command[0] == pytest.approx(robot.spec.robot.max_speed_mps * (1 - robot.spec.slip))
    robot.set_command(0.0, 0.0, 10.0)
    assert abs(robot.command[2]) == pytest.approx(robot.spec.robot.max_omega_rps * (1 - robot.spec.slip))


def test_wheel_slip_moves_the_body_less_than_the_wheels_count():
    robot, space = _robot("r1")
    robot.set_command(0.5, 0.0, 0.0)
    _drive(robot, space, 2.0)
    assert robot.velocity_body[0] == pytest.approx(0.5 * 0.97, rel=1e-6)
    assert robot.wheel_velocity[0] == pytest.approx(0.5, rel=1e-6)  # what the odometry counts
    pet, pspace = _robot("petbot")
    pet.set_command(0.5, 0.0, 0.0)
    _drive(pet, pspace, 2.0)
    assert pet.wheel_velocity == pet.velocity_body  # no slip, nothing in the way: the wheels and the body agree


def test_battery_drain_model():
    spec = resolve(CFG, "r2").battery
    b = Battery(spec, 1.8, 2.5)
    assert b.current_ma((0.0, 0.0, 0.0)) == spec.sensing_ma
    assert b.current_ma((0.9, 0.0, 0.0)) == pytest.approx(spec.sensing_ma + 0.5 * spec.servo_ma)
    assert b.current_ma((1.8, 0.0, 2.5)) == pytest.approx(spec.sensing_ma + spec.servo_ma)  # load capped at 1
    for v in ((0.3, -0.2, 0.7), (1.0, 1.0, -3.0)):  # drain is current_ma written out
        c = Battery(spec, 1.8, 2.5)
        c.drain(36.0, v)
        assert c.remaining_mah == pytest.approx(spec.capacity_mah - c.current_ma(v) / 100.0)
    b.drain(3600.0, (0.0, 0.0, 0.0))  # one hour at rest
    assert b.remaining_mah == pytest.approx(spec.capacity_mah - spec.sensing_ma)
    assert not b.empty
    assert b.drain(1e9, (0.0, 0.0, 0.0)) and b.empty and b.remaining_mah == 0.0
    assert not b.drain(1.0, (0.0, 0.0, 0.0))  # empty once


def test_an_empty_battery_stops_the_robot_and_ignores_its_commands():
    robot, space = _robot("mybot")
    robot.set_command(1.0, 0.0, 0.0)
    _drive(robot, space, 1.0)
    start = robot.battery.remaining_mah
    assert start < robot.battery.capacity_mah  # drained by motion and sensing
    robot.battery.set_remaining(1e-6)
    _drive(robot, space, 0.04)
    assert robot.battery.empty and robot.command == (0.0, 0.0, 0.0)
    robot.set_command(1.0, 0.0, 1.0)
    assert robot.command == (0.0, 0.0, 0.0)
    _drive(robot, space, 2.0)
    assert max(abs(v) for v in robot.velocity_body) < 1e-9
    status = robot.own_status()
    assert status["battery_empty"] and status["type"] == "mybot" and status["battery_mah"] == 0.0
    assert {s["type"] for s in status["sensors"]} == {"DISTANCE", "IR"}


# -- the middle layer ------------------------------------------------------------------------------

def test_mybot_onto_the_default_ring_leaves_two_virtual_sensors_without_a_source():
    m = build_body_map(resolve(CFG, "mybot"), virtual_ring(8, CFG.robot.radius_m))
    # virtual k at 45·k°; mybot has 0, 45, 90, 180, 270, 315: nothing at 135 (k=3) and 225 (k=5)
    assert m.present == (1.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0)
    assert m.location_known == m.present  # angles only (seed 001 §VI.A): every match is exact
    assert m.route == (2, 1, 0, None, 5, None, 4, 3)
    assert not m.identity


def test_mybot_onto_a_12_ring_gives_null_locations_and_presence_0():
    cfg = load_config(overrides={"robot.ultrasonic.count": 12})
    m = build_body_map(resolve(cfg, "mybot"), virtual_ring(12, cfg.robot.radius_m))
    rows = {r.physical: r for r in m.table}
    # 90, 0, 270, 180 sit on the 30° ring: type and location; 45 and 315 (ids 2, 4): type only, NULL location
    assert [(p, rows[p].valid_type, rows[p].valid_location) for p in (1, 3, 5, 6)] == [(p, True, True) for p in (1, 3, 5, 6)]
    assert (rows[2].valid_type, rows[2].valid_location, rows[4].valid_type, rows[4].valid_location) == (True, False, True, False)
    assert sum(m.present) == 6 and sum(m.location_known) == 4
    null = [k for k in range(12) if m.present[k] and not m.location_known[k]]
    assert len(null) == 2 and all(m.route[k] in (1, 3) for k in null)


def test_a_sensor_fault_delivers_nothing():
    m = build_body_map(resolve(CFG, "petbot"), virtual_ring(8, CFG.robot.radius_m))
    flags = m.flags(off={3})
    assert flags[2] == 0.0 and flags[8 + 2] == 0.0 and sum(flags) == 14.0


def test_one_table_per_type():
    bodies = [resolve(CFG, n) for n in ("petbot", "mybot", "mybot", "r1")]
    layer = MiddleLayer(bodies, CFG.robot)
    assert set(layer.by_type) == {"petbot", "mybot", "r1"} and layer.maps[1] is layer.maps[2]
    assert not layer.identity


def test_a_behaviour_no_module_serves_is_refused_naming_it():
    bodies = [resolve(CFG, n) for n in ("petbot", "mybot")]
    attach_check((Behaviour("MOVE", ("vx", "vy", "omega")),), bodies)  # MOVE: every body has it
    with pytest.raises(BehaviourRefused, match="'EMOTION' has no module on robot type 'petbot'"):
        attach_check((Behaviour("EMOTION"),), bodies)
    attach_check((Behaviour("EMOTION"),), bodies[1:])  # mybot has EMOTION (seed 001 Table VII)


def test_a_policy_needing_a_missing_behaviour_is_refused_when_attached():
    from petswarm.baselines.policy import PolicySpec, RandomPolicy
    from petswarm_env.observe import ObservationLayout

    spec = PolicySpec(ObservationLayout(8), 1.5, 2.0, 2.0, (resolve(CFG, "petbot"), resolve(CFG, "r1")))

    class Gripper(RandomPolicy):
        name = "gripper"
        behaviours = RandomPolicy.behaviours + (Behaviour("GRIP"),)

    with pytest.raises(BehaviourRefused, match="'GRIP' has no module on robot type 'petbot' \\(policy 'gripper'\\)"):
        Gripper(spec)
    RandomPolicy(spec)  # MOVE only: attached


def test_odometry_counts_the_wheels_of_a_slipping_body():
    from petswarm_env.sim.sensors import Odometry

    cfg = load_config(overrides={"robot.odometry_noise_rel": 0.0})
    robot, space = _robot("r1", cfg)
    robot.set_command(0.4, 0.0, 0.0)
    _drive(robot, space, 2.0)
    odo = Odometry(robot, cfg.robot, np.random.default_rng(0))
    assert odo.read()[0] == pytest.approx(0.4, rel=1e-6)
    assert math.isclose(robot.velocity_body[0], 0.4 * 0.97, rel_tol=1e-6)


def test_the_heading_yield_lets_a_differential_body_move_first():
    from petswarm_env.mapping import DifferentialLimits, differential_move

    off = DifferentialLimits(1.0, 2.0, 0.5)
    on = DifferentialLimits(1.0, 2.0, 0.5, heading_yield_mps=0.4)
    # a policy holding its heading while asking to move right: the two turns cancel without the yield
    assert differential_move(0.0, -0.5, 1.0, off) == (0.0, pytest.approx(0.0))
    assert differential_move(0.0, -0.5, 1.0, on) == (0.0, pytest.approx(-1.0))  # |Vy| >= 0.4: ω yields whole
    assert differential_move(0.0, 0.0, 1.0, on) == (0.0, 1.0)  # standing: the policy's ω whole
    assert differential_move(0.0, 0.2, 1.0, on) == (0.0, pytest.approx(0.5 + 0.2 / 0.5))  # half the sideways yield
    # driving straight on (its swarm's walk): the policy's ω whole, whatever the speed (the swarm's turn with it)
    assert differential_move(0.9, 0.0, 1.0, on) == (0.9, 1.0)
    with pytest.raises(ValueError, match="heading_yield_mps"):
        DifferentialLimits(1.0, 2.0, 0.5, heading_yield_mps=-1.0)


def test_a_learned_policy_file_declaring_a_behaviour_no_body_has_is_refused(tmp_path):
    from petswarm.baselines.learned import LearnedPolicy, save_policy
    from petswarm.baselines.policy import PolicySpec
    from petswarm_env.observe import ObservationLayout

    layout = ObservationLayout(8)
    layers = [(np.zeros((3, layout.size)), np.zeros(3))]
    spec = PolicySpec(layout, 1.5, 2.0, 2.0, (resolve(CFG, "petbot"), resolve(CFG, "mybot")))
    save_policy(tmp_path / "p.npz", layers, "tanh", layout, behaviours=["MOVE", "EMOTION"])
    with pytest.raises(BehaviourRefused, match="'EMOTION' has no module on robot type 'petbot'"):
        LearnedPolicy.load(tmp_path / "p.npz", spec)
    save_policy(tmp_path / "q.npz", layers, "tanh", layout)  # MOVE: attached to both bodies
    assert [b.name for b in LearnedPolicy.load(tmp_path / "q.npz", spec).behaviours] == ["MOVE"]
