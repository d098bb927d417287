"""The experiments with the user in the loop (``reaction_time``, ``rotation_sync``): an env whose
user stands, then turns on the spot, driven by the scripted swarm."""

from __future__ import annotations

import math

from baselines.policy import PolicySpec
from baselines.registry import make_policy
from petswarm_env.scenarios import ScenarioScript, Segment

TURN_RATE_DPS = 60.0  # seed 002 §4.3: "the angular speed is fixed" (value not given); our user's turn rate
SETTLE_S = 4.0  # the user stands this long after reset before turning (the swarm settles)


def turn_on_the_spot(env, angle_deg: float, rate_dps: float = TURN_RATE_DPS) -> None:
    """Replace the user's script after ``reset``: stand, then turn ``angle_deg`` on the spot, then stand."""
    user = env.world.user
    stand = Segment(SETTLE_S, 0.0, 0.0, "stop")
    turn = Segment(abs(angle_deg) / rate_dps, 0.0, math.copysign(rate_dps, angle_deg), "rest")
    user.script = ScenarioScript([stand, turn, Segment(1e9, 0.0, 0.0, "stop")])
    user.script_time_s = 0.0
    user.segment = user.script.segments[0]


def scripted_policy(env):
    return make_policy("scripted", PolicySpec.from_env(env))


def step(env, pol, obs):
    obs, *_ = env.step(pol.act_all({a: obs[a] for a in env.agents}))
    return obs
