"""End-to-end: the scripted reference builds the formation from the default scattered start and
holds it (from the slots, ``swarm.spawn: at_slots``, within 20 cm) on the default scenario; random does not."""

import json
import math

import pytest

from petswarm.evaluation.runner import run
from petswarm_env.config import load_config

SEEDS = 5


@pytest.fixture(scope="module")
def scripted():
    return run(load_config(overrides={"swarm.spawn": "at_slots"}), "scripted", episodes=SEEDS, seed=0)


def test_scripted_reference_builds_the_wedge_from_the_scattered_start():
    result = run(load_config(), "scripted", episodes=3, seed=0)
    for ep in result["episodes"]:
        assert 0.0 < ep["building_time_s"] < 15.0, ep["building_time_s"]
    assert result["summary"]["formations_built"] == 3 and result["summary"]["formation_rmse_m"] < 1.0


def test_default_scenario_is_a_walk_with_turns_with_four_slaves_in_a_wedge():
    cfg = load_config()
    assert cfg.user.scenario == "zigzag" and cfg.swarm.num_slaves == 4 and cfg.swarm.formation == "wedge"


def test_scripted_reference_keeps_the_wedge_within_20cm(scripted):
    s = scripted["summary"]
    assert s["episodes"] == SEEDS
    assert s["formation_rmse_m"] <= 0.20, s
    for ep in scripted["episodes"]:
        assert ep["slaves"] == 4
        assert ep["steps"] == load_config().max_cycles


def test_scripted_reference_has_no_robot_robot_collision(scripted):
    assert scripted["summary"]["robot_robot_collisions"] == 0


def test_random_policy_is_far_worse(scripted):
    rnd = run(load_config(overrides={"max_cycles": 300}), "random", episodes=2, seed=0)
    assert rnd["summary"]["formation_rmse_m"] > 5 * scripted["summary"]["formation_rmse_m"]


def test_episode_json_has_the_documented_shape(scripted):
    text = json.dumps(scripted)
    data = json.loads(text)
    assert set(data) == {"config", "episodes", "summary"}
    assert set(data["summary"]) >= {"episodes", "formation_rmse_m", "collisions", "organize_time_s", "join_retries"}
    ep = data["episodes"][0]
    for key in ("formation_rmse_m", "collisions", "organize_time_s", "join_retries", "token_recoveries", "frames"):
        assert key in ep
    assert set(ep["frames"]) == {"sent", "lost", "collided"}
    assert ep["foreign_pan_frames_processed"] == 0
    assert math.isfinite(ep["organize_time_s"]) and ep["organize_time_s"] > 0


@pytest.mark.parametrize("formation", ["column", "row", "grid"])
def test_other_formations_hold_on_a_straight_walk(formation):
    cfg = load_config(overrides={"swarm.formation": formation, "user.scenario": "straight", "max_cycles": 300, "swarm.spawn": "at_slots"})
    result = run(cfg, "scripted", episodes=1, seed=0)
    assert result["summary"]["formation_rmse_m"] < 0.3
    assert result["summary"]["robot_robot_collisions"] == 0
