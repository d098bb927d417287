"""The experiments with the user in the loop (``reaction_time``, ``rotation_sync``): an env whose
user stands, then turns on the spot, driven by the scripted swarm."""

from __future__ import annotations

import math

from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.scenarios import ScenarioScript, Segment

TURN_RATE_DPS = 60.0  # seed 002 §4.3: "the angular speed is fixed" (value not given); our user's turn rate
SETTLE_S = 4.0  # the user stands this long after reset before turning (the swarm settles)


def turn_on_the_spot(env, angle_deg: float, rate_dps: float = TURN_RATE_DPS) -> None:
    """Replace the user's script after ``reset``: stand ``SETTLE_S``, then turn ``angle_deg`` on the
    spot, then stand. The turn is exact: the user's script clock advances one physics substep at a
    time, and a segment boundary on a substep instant falls on either side of it by float rounding
    (a 90° turn at 60°/s was 91.2°, a 45° one 45.6°: the scenarios' turns carry the same error), so
    the boundaries fall half a substep early and the user turns for a whole number ``n`` of
    substeps at ``|angle| / (n·dt)``, the rate nearest ``rate_dps`` that makes the angle exact
    (60°/s for 90°, 59.2°/s for 45°; seed 002 §4.3 fixes the angular speed but does not give it)."""
    user = env.world.user
    dt = env.cfg.control_period_s / env.cfg.physics_substeps
    n = max(1, round(abs(angle_deg) / rate_dps / dt))
    stand = Segment(SETTLE_S - dt / 2, 0.0, 0.0, "stop")
    turn = Segment(n * dt, 0.0, math.copysign(abs(angle_deg) / (n * dt), angle_deg), "rest")
    user.script = ScenarioScript([stand, turn, Segment(1e9, 0.0, 0.0, "stop")])
    user.script_time_s = 0.0
    user.segment = user.script.segments[0]


def scripted_policy(env):
    return make_policy("scripted", PolicySpec.from_env(env))


def step(env, pol, obs):
    obs, *_ = env.step(pol.act_all({a: obs[a] for a in env.agents}))
    return obs
