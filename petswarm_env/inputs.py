"""What a caller hands the environment at run time, checked: ``reset``'s options, the actions of
``step`` (the raw env's and :class:`~petswarm_env.wrappers.FixedAgents`'), and the start of an
episode against the config's boxes. Every refusal is one line that names the argument, the agent
or the key, and what is allowed (the config's own checks are in :mod:`petswarm_env.config`)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable
from typing import Any

import numpy as np

from petswarm_env.config import describe_value

# the keys reset(options=...) takes: none yet (PettingZoo passes None); any other key is a mistake
# the env would otherwise ignore
RESET_OPTIONS: tuple[str, ...] = ()


class ResetOptionWarning(UserWarning):
    """``reset(options=...)`` named a key this env does not take (it is ignored)."""


def check_reset_options(options: Any) -> None:
    """``reset(options=...)``: ``None`` or a dict (anything else is a ``TypeError``). A key not in
    :data:`RESET_OPTIONS` is ignored with a :class:`ResetOptionWarning` naming it, not refused:
    PettingZoo's own API test (``parallel_api_test``) resets with ``options={"options": 1}`` to
    check that any dict is taken."""
    if options is None:
        return
    if not isinstance(options, dict):
        raise TypeError(f"reset(options=...) takes a dict or None, got {describe_value(options)}")
    unknown = [k for k in options if k not in RESET_OPTIONS]
    if unknown:
        allowed = ", ".join(RESET_OPTIONS) if RESET_OPTIONS else "none (pass options=None)"
        warnings.warn(f"reset(options=...) ignores {', '.join(describe_value(k) for k in unknown[:3])}: the options this env "
                      f"takes: {allowed}", ResetOptionWarning, stacklevel=3)


def _holds_bool(value: Any) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return True
    if isinstance(value, np.ndarray):
        return value.dtype.kind == "b"
    if isinstance(value, (list, tuple)):
        return any(_holds_bool(v) for v in value)
    return False


def checked_action(agent: str, action: Any) -> np.ndarray:
    """One agent's action as a float32 array of 3 finite numbers clipped to [-1, 1], or an
    error naming the agent: not numbers (a boolean, ``np.bool_`` included, is not a speed), the
    wrong shape, NaN or infinity."""
    if _holds_bool(action):
        raise ValueError(f"action of {agent} holds a boolean, {describe_value(action)}; give 3 numbers (Vx, Vy, ω) in [-1, 1]")
    try:
        raw = np.asarray(action)
    except ValueError:  # ragged nested sequences
        raw = None
    if raw is None or raw.dtype.kind not in "iuf":
        raise ValueError(f"action of {agent} must be 3 numbers (Vx, Vy, ω) in [-1, 1], got {describe_value(action)}")
    with np.errstate(over="ignore", invalid="ignore"):  # beyond float32: infinite, refused below
        arr = raw.astype(np.float32)
    if arr.shape != (3,):
        raise ValueError(f"action of {agent} must have shape (3,) = (Vx, Vy, ω) in [-1, 1], got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"action of {agent} contains NaN or inf (or a number beyond float32): {raw.tolist()}; actions must be finite")
    return np.clip(arr, -1.0, 1.0)


def check_actions(actions: Any, agents: Iterable[str], what: str = "agents") -> None:
    """The actions of a ``step``: a dict whose keys are all in ``agents`` (``what`` says which set:
    the live agents, or a wrapper's fixed ones) and whose values are actions (:func:`checked_action`).
    Raises ``TypeError``, ``KeyError`` or ``ValueError`` as the raw env does."""
    if not isinstance(actions, dict):
        raise TypeError(f"actions must be a dict agent -> array of 3 floats, got {type(actions).__name__}")
    agents = list(agents)
    unknown = set(actions) - set(agents)
    if unknown:
        raise KeyError(f"actions for agents not in the episode: {sorted(map(str, unknown))}; {what}: {agents}")
    for agent, action in actions.items():
        checked_action(agent, action)


def _overlap(x: float, y: float, r: float, box: Any) -> bool:
    (cx, cy), (w, h) = box.center_m, box.size_m
    dx = max(abs(x - cx) - w / 2, 0.0)
    dy = max(abs(y - cy) - h / 2, 0.0)
    return math.hypot(dx, dy) < r


def check_start_clear_of_boxes(cfg: Any, world: Any) -> None:
    """No robot or user starts inside or touching a box of ``world.obstacles``: the physics
    would push it out on the first step (or hold it stuck), so a box on the start positions is
    refused at reset, naming the box and the body."""
    if not cfg.world.obstacles:
        return
    bodies = [(f"robot_{r.index}", r.position, r.radius_m) for r in world.robots]
    bodies += [(f"user {u.index}", u.position, cfg.user.radius_m) for u in world.users]
    for i, box in enumerate(cfg.world.obstacles):
        for name, (x, y), r in bodies:
            if _overlap(float(x), float(y), float(r), box):
                (cx, cy), (w, h) = box.center_m, box.size_m
                raise ValueError(
                    f"world.obstacles[{i}] (centre [{cx:g}, {cy:g}], size [{w:g}, {h:g}] m) lies on the start of {name} "
                    f"at ({x:.2f}, {y:.2f}) m: the users start at (0, k x world.user_spacing_m) and their swarms within "
                    "protocol.join_radius_m of them; move the box away from the start")
