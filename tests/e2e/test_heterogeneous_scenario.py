"""End-to-end: the ``heterogeneous`` scenario — a petbot master and a pool of one
petbot, one mybot (seed 001, differential), one r1 and one r2 (seed 003's R1, R2) — held by the
scripted reference from the slots (``swarm.spawn: at_slots``): formation RMSE <= 0.25 m, no
collisions, seeds 0–4 (the figures of docs/results.md). From the scattered start it builds, but looser (docs/results.md
says by how much)."""

import pytest

from petswarm.evaluation.runner import run
from petswarm_env.config import load_config

SEEDS = 5


@pytest.fixture(scope="module")
def hetero():
    cfg = load_config(overrides={"user.scenario": "heterogeneous", "swarm.spawn": "at_slots"})
    return run(cfg, "scripted", episodes=SEEDS, seed=0)


def test_the_mixed_swarm_holds_the_wedge_within_25cm(hetero):
    s = hetero["summary"]
    assert s["episodes"] == SEEDS
    assert s["formation_rmse_m"] <= 0.25, s
    for ep in hetero["episodes"]:
        assert ep["slaves"] == 4 and ep["formation_rmse_m"] <= 0.25, ep["formation_rmse_m"]


def test_the_mixed_swarm_has_no_collision(hetero):
    s = hetero["summary"]
    assert s["robot_robot_collisions"] == 0
    for ep in hetero["episodes"]:
        assert sum(ep["collisions"].values()) == 0, ep["collisions"]


def test_the_scattered_mixed_swarm_builds_and_runs():
    result = run(load_config(overrides={"user.scenario": "heterogeneous"}), "scripted", episodes=1, seed=0)
    ep = result["episodes"][0]
    assert ep["slaves"] == 4 and ep["steps"] == load_config().max_cycles and ep["formation_rmse_m"] < 2.0


def test_the_mixed_swarm_builds_from_the_slots(hetero):
    # seeds 2 and 4 within 3 s; seeds 0, 1 and 3 once the user walks off (user.formation_wait_s = 30 s):
    # a differential slave holds 0.3-0.4 m off its slot while standing (docs/results.md, "A heterogeneous swarm";
    # seed 3 built in 2.9 s while the odometry read the body's true velocity, in 32.6 s with the wheels')
    times = [ep["building_time_s"] for ep in hetero["episodes"]]
    assert all(t < 40.0 for t in times) and sum(t < 3.0 for t in times) >= 2, times
