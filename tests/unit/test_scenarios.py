"""The scenario registry (petswarm_env/scenarios/): every registered scenario builds its script and
places its robots; the config takes its names; adding one is registering one object."""

import math

import numpy as np
import pytest

import petswarm_env
from petswarm_env import scenarios
from petswarm_env.config import ConfigError, load_config
from petswarm_env.middleware.formation import formation_for_mode, leading_user
from petswarm_env.middleware.master_role import master_distance_m
from petswarm_env.scenarios import SCENARIOS, Placement, Scenario, Segment
from petswarm_env.sim.world import World

PAPER_ORDER = ["straight", "turn_left_60", "turn_right_60", "zigzag", "u_turn", "stop_and_go", "random_walk", "mode_change"]
ISSUE_15 = ["heterogeneous", "dropout", "master_loss", "arrival"]  # scenarios/heterogeneous.py, runtime_changes.py


def test_the_registry_holds_the_named_scenarios_in_order():
    assert list(SCENARIOS) == [*PAPER_ORDER, *ISSUE_15]  # the walks first, then the other modules by file name
    assert all(SCENARIOS[n].name == n for n in SCENARIOS)
    assert [n for n in SCENARIOS if SCENARIOS[n].changes_master] == ["mode_change"]


@pytest.mark.parametrize("name", list(SCENARIOS))
@pytest.mark.parametrize("mode", ["following", "leading"])
def test_every_scenario_builds_its_script_and_places_its_robots(name, mode):
    cfg = load_config(overrides={"user.scenario": name, "swarm.mode": mode, "swarm.extra_robots": 2,
                                 "swarm.other_user_robots": 1, "world.num_users": 2})
    scenario = SCENARIOS[name]
    segs = scenario.segments(cfg.user, np.random.default_rng(0))
    assert segs[0] == Segment(cfg.user.start_delay_s, 0.0, 0.0, "stop") and segs[-1].duration_s >= 1e9
    assert all(s.duration_s > 0 and s.activity in scenarios.ACTIVITIES for s in segs)
    assert all(not s.command or s.command in scenarios.USER_COMMANDS for s in segs)
    world = World(cfg, scenario.script(cfg.user, np.random.default_rng(0)))
    plan = formation_for_mode(cfg.swarm, cfg.swarm.num_slaves + 1, mode, leading_user(cfg))
    placed = scenario.place(world, cfg, plan.slot_positions(), master_distance_m(cfg, None, mode), np.random.default_rng(1))
    assert isinstance(placed, Placement) and len(placed.pools) == 2
    n = cfg.swarm.num_slaves + cfg.swarm.extra_robots
    indices = [i for master, pool in placed.pools for i in (master, *pool)] + placed.other_user_robots
    assert sorted(indices) == list(range(len(world.robots))) == list(range(2 * (1 + n) + 1))
    for u, (master, pool) in enumerate(placed.pools):  # the user's own robot starts in LF wake-up range, facing them
        robot = world.robots[master]
        assert math.dist(robot.position, (0.0, u * cfg.world.user_spacing_m)) <= cfg.lf.wake_range_m
        assert robot.heading == (math.pi if mode == "leading" else 0.0)
        assert len(pool) == n
        for i in pool[: cfg.swarm.num_slaves]:  # waiting robots inside the master's available region
            assert math.dist(world.robots[i].position, robot.position) < cfg.protocol.join_radius_m + 2.0


def test_the_placement_draws_only_from_its_stream():
    cfg = load_config()
    plan = formation_for_mode(cfg.swarm, cfg.swarm.num_slaves + 1, cfg.swarm.mode, leading_user(cfg))
    worlds = []
    for _ in range(2):
        world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
        SCENARIOS["straight"].place(world, cfg, plan.slot_positions(), 1.0, np.random.default_rng(4))
        worlds.append([r.position for r in world.robots])
    assert worlds[0] == worlds[1]


def test_random_walk_draws_from_the_script_stream_and_mode_change_asks_for_leading():
    user = load_config().user
    a, b = (SCENARIOS["random_walk"].segments(user, np.random.default_rng(s)) for s in (1, 2))
    assert len(a) == 2 + 80 and a != b
    turn = [s for s in SCENARIOS["mode_change"].segments(user, None) if s.command]
    assert [s.command for s in turn] == ["mode:leading"] and turn[0].turn_rate_dps * turn[0].duration_s == pytest.approx(180.0)


def test_config_validates_scenario_names_against_the_registry():
    with pytest.raises(ConfigError, match="user.scenario.*'straight'.*'mode_change'"):
        load_config(overrides={"user.scenario": "moonwalk"})
    with pytest.raises(ConfigError, match="user.scenario_pool"):
        load_config(overrides={"user.scenario_pool": ["zigzag", "moonwalk"]})
    with pytest.raises(ValueError, match="choose one of: straight, turn_left_60"):
        scenarios.get("moonwalk")
    assert scenarios.get("zigzag") is SCENARIOS["zigzag"]


def test_a_registered_scenario_is_a_config_choice_and_runs(monkeypatch):
    """Adding a scenario is registering one object: the config and the env take it as it is."""

    class Circle(Scenario):
        name = "test_circle"

        def walk(self, user, rng):
            return [Segment(10.0, user.walk_speed_mps, 36.0, "walk")]

    with pytest.raises(ConfigError, match="user.scenario"):
        load_config(overrides={"user.scenario": "test_circle"})
    monkeypatch.setitem(SCENARIOS, "test_circle", Circle())
    with pytest.raises(ValueError, match="needs a new name"):
        scenarios.register(Circle())
    env = petswarm_env.parallel_env(**{"user.scenario": "test_circle", "max_cycles": 40, "user.formation_wait_s": 0.0})
    obs, _ = env.reset(seed=0)
    assert env.scenario == "test_circle" and env.agents
    while env.agents:
        obs, *_ = env.step({a: np.zeros(3, np.float32) for a in env.agents})
    assert env.episode.world.user.segment.turn_rate_dps == 36.0


def _walk(segments, start=(0.0, 0.0), heading=0.0, horizon_s=2000.0, dt=0.05):
    """The user's path along ``segments`` (closed-form arcs, every ``dt``), up to ``horizon_s``."""
    from petswarm_env.scenarios.base import _arc

    x, y, th, t, path = *start, heading, 0.0, []
    for seg in segments:
        done = 0.0
        while done < seg.duration_s and t < horizon_s:
            step = min(dt, seg.duration_s - done)
            x, y, th = _arc(x, y, th, seg.speed_mps, math.radians(seg.turn_rate_dps), step)
            done, t = done + step, t + step
            path.append((x, y))
        if t >= horizon_s:
            break
    return np.array(path)


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_the_script_turns_back_at_the_walls(name):
    """In a 20 000-step zigzag the user walked through the arena wall at step 1 373. With
    the turn-back rule every named script keeps the user inside the walls minus the swarm's reach
    and a clearance over 2 000 s in a 20 m arena; without it the same walk leaves the arena."""
    from petswarm_env.scenarios.base import TURN_BACK_CLEARANCE_M, Arena, turn_back_radius_m

    user = load_config().user
    reach = 4.8
    scenario = SCENARIOS[name]
    margin = scenario.turn_back_margin_m(user, reach)
    assert margin == pytest.approx(reach + 2 * turn_back_radius_m(user) + TURN_BACK_CLEARANCE_M)
    arena = Arena((10.0, 10.0), margin, (0.0, 2.0), 0.0, 2000.0)
    plain = scenario.segments(user, np.random.default_rng(3))
    turned = scenario.script(user, np.random.default_rng(3), arena).segments
    path = _walk(turned, arena.start_m)
    assert np.abs(path).max() <= 10.0 - reach - TURN_BACK_CLEARANCE_M
    assert np.abs(_walk(plain, arena.start_m)).max() > 10.0  # the leak it closes
    def is_back(s):  # a 180° walking turn at half the walking speed
        return s.speed_mps == 0.5 * user.walk_speed_mps and abs(s.turn_rate_dps) == user.turn_rate_dps \
            and s.duration_s == pytest.approx(180.0 / user.turn_rate_dps) and s.activity == "walk"

    assert sum(map(is_back, turned)) > sum(map(is_back, plain))
    assert [s.command for s in turned if s.command] == [s.command for s in plain if s.command]  # each given once
    finite = lambda segs: sum(s.duration_s for s in segs[:-1])  # noqa: E731  (the last one repeats)
    assert finite(turned) + turned[-1].duration_s - plain[-1].duration_s == pytest.approx(
        finite(plain) + (sum(map(is_back, turned)) - sum(map(is_back, plain))) * 180.0 / user.turn_rate_dps)


def test_without_walls_or_far_from_them_the_script_is_unchanged():
    cfg = load_config()
    scenario = SCENARIOS["zigzag"]
    assert scenario.arena(load_config(overrides={"world.arena_m": [0, 0]}), 3.0, 0) is None
    arena = scenario.arena(cfg, 3.0, 0)
    assert arena.half_m == (100.0, 100.0) and arena.horizon_s == pytest.approx(60.0)
    assert scenario.script(cfg.user, np.random.default_rng(0), arena).segments == scenario.segments(cfg.user, None)


def test_an_arena_that_cannot_hold_the_walk_is_refused_naming_the_keys():
    """A configuration whose users would walk into a wall and cannot turn back inside is refused by
    the env with one line naming the arena, the speed, max_cycles and the scenario."""
    with pytest.raises(ConfigError) as exc:
        petswarm_env.parallel_env(**{"world.arena_m": [10.0, 10.0], "user.scenario": "straight"})
    text = str(exc.value)
    assert "\n" not in text
    for key in ("world.arena_m", "user.walk_speed_mps", "max_cycles=600", "user.scenario='straight'", "[0, 0]"):
        assert key in text
    petswarm_env.parallel_env(**{"world.arena_m": [13.0, 13.0], "max_cycles": 5})  # 0.5 m of walk: fits without turning
    petswarm_env.parallel_env(**{"world.arena_m": [16.0, 16.0], "max_cycles": 20000})  # turns back inside
    petswarm_env.parallel_env(**{"world.arena_m": [0.0, 0.0], "max_cycles": 20000})  # no walls
    with pytest.raises(ConfigError, match="user 1"):
        petswarm_env.parallel_env(**{"world.arena_m": [16.0, 16.0], "world.num_users": 2})
