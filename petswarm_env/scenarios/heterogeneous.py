"""``heterogeneous``: a mixed pool — one of each shipped robot type, seed 003's
heterogeneous swarm with seed 001's Mybot — accompanying a user on seed 002 Fig. 18a's walk
(8 s straight, a 60° left turn, then straight on). The master is the user's petbot; each slave
is its body mapped onto the env's virtual robot (petswarm_env/middle_layer.py)."""

from __future__ import annotations

from petswarm_env.scenarios.base import Scenario, Segment, register, turn


class Heterogeneous(Scenario):
    name = "heterogeneous"
    robot_pool = (("petbot", 1), ("mybot", 1), ("r1", 1), ("r2", 1))  # default.yaml robot_types

    def walk(self, user, rng):
        return [Segment(8.0, user.walk_speed_mps, 0.0, "walk"), turn(60.0, user.turn_rate_dps, user.walk_speed_mps)]


register(Heterogeneous())
