"""No shared frame (seed 000 §3.5): nothing a robot knows is in the world frame.

Each robot's AHRS reads yaw relative to its own power-on heading (seed 000 §3.5: no compass; every
relative heading comes from the heading exchange). So turning the whole initial scene — robots,
users and their scripts (the script turns with the user's heading) — about the origin by any angle
must leave every observation the same: only float64 rounding differs between the two worlds. A
rounding difference can grow (a flipped threshold), so the check is over the first 10 s, within a
tolerance far below any real signal (positions are in units of 3 m, an IR bearing's noise is 5°;
a shared frame shows in ``self.yaw_sincos`` by the rotation angle itself, up to 2 in a value).
Measured: the float32 observations of the three scenes below are bit-identical over 200 steps,
the default scene's over its whole 600-step episode (the closed loop damps the rounding).

No wall is within sensor range: the default arena is 200 m wide and the scene sits at its centre.
"""

import math

import numpy as np
import pytest

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.sim.world import World

STEPS = 100  # 10 s: organized, driving, the user walking and turning
TOLERANCE = 1e-5  # in observation units (positions / 3 m: 0.03 mm; angles' sin/cos), a few float32 steps


def _rotated_world(monkeypatch, angle):
    """Every body the scenario adds (robots, users) goes in turned about the origin by ``angle``."""
    c, s = math.cos(angle), math.sin(angle)
    add_robot, add_user = World.add_robot, World.add_user

    def turn(p):
        x, y = float(p[0]), float(p[1])
        return (c * x - s * y, s * x + c * y)

    monkeypatch.setattr(World, "add_robot", lambda self, p, th: add_robot(self, turn(p), th + angle))
    monkeypatch.setattr(World, "add_user", lambda self, script, p, th: add_user(self, script, turn(p), th + angle))


def assert_same_observations(straight, turned, layout, tolerance=TOLERANCE):
    """Every step's observations of two traces agree within ``tolerance``; a failure names the fields."""
    worst = 0.0
    for step, (a, b) in enumerate(zip(straight, turned)):
        assert sorted(a) == sorted(b), f"step {step}: agents differ"
        for agent in a:
            diff = float(np.max(np.abs(a[agent].astype(np.float64) - b[agent])))
            if diff > tolerance:
                bad = [f.name for f in layout.fields
                       if np.max(np.abs(a[agent][layout.slices[f.name]] - b[agent][layout.slices[f.name]])) > tolerance]
                pytest.fail(f"step {step}, {agent}: observation differs by {diff:.3g} in {bad}")
            worst = max(worst, diff)
    assert worst < tolerance


def _trace(overrides, seed, steps):
    env = petswarm_env.parallel_env(max_cycles=steps, **overrides)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed)
    obs, _ = env.reset(seed=seed)
    policy.reset(seed)
    trace = [obs]
    for _ in range(steps):
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        trace.append(obs)
    return trace, env


@pytest.mark.parametrize("overrides, seed, angle", [
    ({}, 3, 2.0),
    ({"swarm.mode": "leading", "user.scenario": "turn_left_60"}, 5, -1.1),
    ({"world.num_users": 2, "swarm.num_slaves": 2}, 7, math.pi / 2 + 0.3),
], ids=["following", "leading", "two users"])
def test_turning_the_whole_scene_leaves_every_observation_the_same(monkeypatch, overrides, seed, angle):
    straight, env = _trace(overrides, seed, STEPS)
    with monkeypatch.context() as m:
        _rotated_world(m, angle)
        turned, env_turned = _trace(overrides, seed, STEPS)
    # the scene did turn: the first robot's true heading differs by the angle
    assert math.remainder(env_turned.episode.world.robots[0].heading - env.episode.world.robots[0].heading - angle, 2 * math.pi) == pytest.approx(0.0, abs=1e-3)
    assert_same_observations(straight, turned, env.layout)
