"""The named scenarios: the trajectory tests of seed 002 Fig. 18 (60° left/right turns, zigzag,
U-turn, the mode change of Fig. 18d) give the shapes, and a few of ours; durations are chosen.
All use the default robot placement (:meth:`~.base.Scenario.place`)."""

from __future__ import annotations

from petswarm_env.scenarios.base import Scenario, Segment, register, turn


class Straight(Scenario):
    """The user walks straight on."""

    name = "straight"


class Turn60(Scenario):
    """Seed 002 Fig. 18a/b: 8 s straight, then a 60° walking turn to the left (``sign`` +1) or right."""

    def __init__(self, name: str, sign: float):
        self.name, self.sign = name, sign

    def walk(self, user, rng):
        return [Segment(8.0, user.walk_speed_mps, 0.0, "walk"), turn(60.0 * self.sign, user.turn_rate_dps, user.walk_speed_mps)]


class Zigzag(Scenario):
    """Seed 002 Fig. 18c: 6 s legs joined by turns of 45°, then six times −90° and +90°."""

    name = "zigzag"

    def walk(self, user, rng):
        walk, rate = user.walk_speed_mps, user.turn_rate_dps
        leg = Segment(6.0, walk, 0.0, "walk")
        body = [leg, turn(45.0, rate, walk)]
        for _ in range(6):
            body += [leg, turn(-90.0, rate, walk), leg, turn(90.0, rate, walk)]
        return body


class UTurn(Scenario):
    """8 s straight, then a 180° turn at half the walking speed."""

    name = "u_turn"

    def walk(self, user, rng):
        return [Segment(8.0, user.walk_speed_mps, 0.0, "walk"), turn(180.0, user.turn_rate_dps, 0.5 * user.walk_speed_mps)]


class StopAndGo(Scenario):
    """Six times: walk 6 s, stand 3 s."""

    name = "stop_and_go"

    def walk(self, user, rng):
        body = []
        for _ in range(6):
            body += [Segment(6.0, user.walk_speed_mps, 0.0, "walk"), Segment(3.0, 0.0, 0.0, "stop")]
        return body


class RandomWalk(Scenario):
    """40 seeded legs of 2–6 s, each followed by a turn of up to ±90° (drawn from the script's stream)."""

    name = "random_walk"

    def walk(self, user, rng):
        body = []
        for _ in range(40):
            body.append(Segment(float(rng.uniform(2.0, 6.0)), user.walk_speed_mps, 0.0, "walk"))
            body.append(turn(float(rng.uniform(-90.0, 90.0)), user.turn_rate_dps, user.walk_speed_mps))
        return body


class ModeChange(Scenario):
    """Seed 002 Fig. 18d: following, then the user turns back (180° at half speed) and walks back,
    asking for leading as they turn; seed 000 Table 3 may make another robot the master."""

    name = "mode_change"
    changes_master = True

    def walk(self, user, rng):
        rate = user.turn_rate_dps
        return [Segment(8.0, user.walk_speed_mps, 0.0, "walk"),
                Segment(180.0 / rate, 0.5 * user.walk_speed_mps, rate, "walk", "mode:leading")]


for _scenario in (Straight(), Turn60("turn_left_60", 1.0), Turn60("turn_right_60", -1.0), Zigzag(), UTurn(), StopAndGo(),
                  RandomWalk(), ModeChange()):
    register(_scenario)
