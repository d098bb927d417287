"""What makes a robot its user's master, apart from the session that drives it: how far from its user
it drives in each mode, whether its body can be one (the LF antennas, seed 002 §3.2), and what it
broadcasts about its user (seed 000 §3.5)."""

from __future__ import annotations

from dataclasses import dataclass

from petswarm_env.config import Config
from petswarm_env.middleware.formation import formation_for_mode, leading_user, leading_user_x


def master_distance_m(cfg: Config, formation, mode: str) -> float:
    """The master's distance to its user: ``master.distance_m`` in following; in leading beyond the
    formation's depth (the planned one while not organized), capped inside the LF range."""
    d = cfg.master.distance_m
    if mode != "leading":
        return d
    if formation is None:
        formation = formation_for_mode(cfg.swarm, cfg.swarm.num_slaves + 1, "leading", leading_user(cfg))
    return leading_user_x(float(formation.slot_positions()[:, 0].max()), leading_user(cfg))


def can_be_master(robot) -> bool:
    """Whether a robot's body carries the two LF antennas a master bursts LF with (robot_types; a
    robot built without a type is a petbot, which does)."""
    return robot.spec is None or robot.spec.can_be_master


@dataclass
class UserView:
    """The master's current knowledge of its user, as it broadcasts it to the slaves (and, the way the user
    walks, as it hands them over for a broken part: modes.ModeManager.change)."""

    activity: str
    user_turn_rate_rps: float
    user_rotating: bool
    user_position_m: tuple[float, float]
    walk_direction_rad: float | None = None  # ψ, its controller's estimate of the user's walk (body frame)
