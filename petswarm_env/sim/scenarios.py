"""Named user scenarios: what the walking user does, as a script of segments.

A segment is ``(duration_s, speed_mps, turn_rate_dps, activity, command)``; the user walks at
``speed`` along its heading while the heading turns at ``turn_rate``; ``command`` (optional) is what
the user tells the robots through the watch when the segment starts (see
:data:`USER_COMMANDS`). The last segment repeats until the episode ends. Trajectory tests of seed 002 Fig. 18 (60° left/right turns, zigzag, U-turn) give the
shapes; durations are chosen.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from petswarm_env.config import SCENARIOS, UserConfig

ACTIVITIES = ("stop", "rest", "walk", "run")  # seed 002 Table 2
# What a user can tell the robots through the smart watch (seed 002 §2, Fig. 4; seed 000 Fig. 4):
# the driving mode, organize / disperse the swarm, return from an exception, and the seven
# remote-control gestures of seed 002 Table 1 ("gesture:forward", ...).
USER_COMMANDS = ("mode:following", "mode:leading", "mode:remote", "organize", "disperse", "return")


@dataclass(frozen=True)
class Segment:
    duration_s: float
    speed_mps: float
    turn_rate_dps: float
    activity: str
    command: str = ""


def _turn(angle_deg: float, rate_dps: float, speed: float) -> Segment:
    """A turn of ``angle_deg`` (positive = left / CCW) while walking at ``speed``."""
    return Segment(abs(angle_deg) / rate_dps, speed, rate_dps if angle_deg > 0 else -rate_dps, "walk")


def build_scenario(name: str, cfg: UserConfig, rng: np.random.Generator) -> list[Segment]:
    """The segment list of a named scenario (``random_walk`` draws from ``rng``)."""
    if name not in SCENARIOS:
        raise ValueError(f"unknown scenario '{name}'; choose one of: {', '.join(SCENARIOS)}")
    walk, rate = cfg.walk_speed_mps, cfg.turn_rate_dps
    straight = Segment(1e9, walk, 0.0, "walk")
    stand = Segment(cfg.start_delay_s, 0.0, 0.0, "stop")
    if name == "straight":
        body = []
    elif name in ("turn_left_60", "turn_right_60"):  # seed 002 Fig. 18a/b
        sign = 1.0 if name == "turn_left_60" else -1.0
        body = [Segment(8.0, walk, 0.0, "walk"), _turn(60.0 * sign, rate, walk)]
    elif name == "zigzag":  # seed 002 Fig. 18c
        leg = Segment(6.0, walk, 0.0, "walk")
        body = [leg, _turn(45.0, rate, walk)]
        for _ in range(6):
            body += [leg, _turn(-90.0, rate, walk), leg, _turn(90.0, rate, walk)]
    elif name == "mode_change":  # seed 002 Fig. 18d: following, then the user turns and walks back;
        # the user asks for leading as they turn
        turn = Segment(180.0 / rate, 0.5 * walk, rate, "walk", "mode:leading")
        return [stand, Segment(8.0, walk, 0.0, "walk"), turn, straight]
    elif name == "u_turn":
        body = [Segment(8.0, walk, 0.0, "walk"), _turn(180.0, rate, 0.5 * walk)]
    elif name == "stop_and_go":
        body = []
        for _ in range(6):
            body += [Segment(6.0, walk, 0.0, "walk"), Segment(3.0, 0.0, 0.0, "stop")]
    else:  # random_walk: seeded legs and turns
        body = []
        for _ in range(40):
            body.append(Segment(float(rng.uniform(2.0, 6.0)), walk, 0.0, "walk"))
            body.append(_turn(float(rng.uniform(-90.0, 90.0)), rate, walk))
    return [stand, *body, straight]


class ScenarioScript:
    """Evaluates a segment list at a time: speed, turn rate and activity of the user."""

    def __init__(self, segments: list[Segment]):
        self.segments = segments
        self.ends = np.cumsum([s.duration_s for s in segments]).tolist()  # floats: read every substep
        self._last = len(self.ends) - 1
        self._i = 0

    def at(self, t_s: float) -> Segment:
        i = self._i
        while i < self._last and t_s >= self.ends[i]:
            i += 1
        self._i = i
        return self.segments[i]
