"""Smart watch: gesture commands of seed 002 §3.1, Table 1, and the remote driver they steer.

Seed 002 §3.1: "The smart watch in this system is used to give commands whenever the robot
requires it, exception situation and remote-control mode ... we use the seven basic gesture
patterns shown in Table 1. Through a combination of gestures, the robot can even move in a diagonal
direction. The principle of this function is based on analyzing the pattern of accelerometer
values." Table 1:

    Circle    Cancel (return to command wait mode)
    Forward   Move forward            Backward  Move backward
    Up        Rotate counter-clockwise 90°
    Down      Rotate clockwise 90°
    Left      Move left               Right     Move right

The paper gives no recognition algorithm or timing, so this module chooses a small one and says so:

* *Signal* (:func:`gesture_trace`): the wrist accelerometer (x along the pointing forearm, y to the
  left, z up) during one stroke of ``gesture_duration_s``. A straight stroke accelerates then
  brakes the hand along its axis, ``A·sin(2πt/T)``; a circle is drawn in the y–z plane (centripetal
  acceleration of constant magnitude A turning once). Sloppiness: the stroke direction is off-axis
  by ``cross_axis_leak`` (σ, fraction) and every sample carries noise; gravity sits on z.
* *Recognition* (:func:`recognise_gesture`): remove the mean (gravity); if the two strongest axes
  carry comparable energy (ratio ≥ ``circle_energy_ratio``) it is a Circle; otherwise the strongest
  axis and the sign of its correlation with the stroke template name the gesture. Misrecognitions
  come out of the sloppiness and noise, not out of a probability.
* *Timing*: a gesture performed at ``t`` is recognised at ``t + recognition_delay_s``.
* *Combination*: a Forward/Backward and a Left/Right recognised within ``combination_window_s`` of
  each other give a diagonal move. The first move is delivered at once (no added latency); the
  second arrives as a diagonal command that replaces it.

:class:`RemoteDriver` turns delivered commands into body-frame ``(vx, vy, ω)`` for the robot
(x forward, y left, ω counter-clockwise; m/s and rad/s). Gesture directions are in the robot's body
frame (the user points the way the robot should go).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from petswarm_env.config import WatchConfig

GESTURES = ("circle", "forward", "backward", "up", "down", "left", "right")  # seed 002 Table 1
MOVE_DIRECTIONS = {  # body-frame unit vectors of the move gestures (Table 1)
    "forward": (1.0, 0.0),
    "backward": (-1.0, 0.0),
    "left": (0.0, 1.0),
    "right": (0.0, -1.0),
}
TURN_SIGNS = {"up": 1, "down": -1}  # Up = counter-clockwise, Down = clockwise (Table 1)
# Watch-frame axis and sign of each straight stroke: x forward, y left, z up.
_STROKES = {
    "forward": (0, 1.0),
    "backward": (0, -1.0),
    "left": (1, 1.0),
    "right": (1, -1.0),
    "up": (2, 1.0),
    "down": (2, -1.0),
}
_STROKE_OF = {v: k for k, v in _STROKES.items()}
_GRAVITY_MPS2 = 9.80665
_EPS_S = 1e-9


@dataclass(frozen=True)
class Command:
    """A recognised command, as the watch sends it over BLE."""

    kind: str  # "move" | "rotate" | "cancel"
    gestures: tuple[str, ...]  # the recognised gesture(s); two for a diagonal
    direction: tuple[float, float]  # body-frame unit vector of a move (x forward, y left); (0, 0) otherwise
    turn_sign: int  # +1 counter-clockwise (Up), -1 clockwise (Down), 0 otherwise
    performed_s: float  # start of the (last) gesture
    recognised_s: float  # when the watch recognised it

    @property
    def diagonal(self) -> bool:
        return self.kind == "move" and len(self.gestures) == 2


def command_of(gesture: str, performed_s: float, recognised_s: float) -> Command:
    """Table 1: the command of one recognised gesture."""
    if gesture == "circle":
        return Command("cancel", (gesture,), (0.0, 0.0), 0, performed_s, recognised_s)
    if gesture in TURN_SIGNS:
        return Command("rotate", (gesture,), (0.0, 0.0), TURN_SIGNS[gesture], performed_s, recognised_s)
    if gesture in MOVE_DIRECTIONS:
        return Command("move", (gesture,), MOVE_DIRECTIONS[gesture], 0, performed_s, recognised_s)
    raise ValueError(f"gesture '{gesture}' is not one of {', '.join(GESTURES)}")


def combine(first: Command, second: Command) -> Command | None:
    """Diagonal of a Forward/Backward and a Left/Right move (either order); None if they do not combine."""
    if not (first.kind == second.kind == "move") or first.diagonal or second.diagonal:
        return None
    (x1, y1), (x2, y2) = first.direction, second.direction
    if (x1 == 0.0) == (x2 == 0.0):  # same family (both longitudinal or both lateral)
        return None
    dx, dy = x1 + x2, y1 + y2
    norm = math.hypot(dx, dy)
    return Command("move", first.gestures + second.gestures, (dx / norm, dy / norm), 0, second.performed_s, second.recognised_s)


# --------------------------------------------------------------------------- signal and recognition


def _template(n: int) -> np.ndarray:
    return np.sin(2.0 * math.pi * (np.arange(n) + 0.5) / n)


def gesture_trace(cfg: WatchConfig, gesture: str, rng: np.random.Generator) -> np.ndarray:
    """Wrist accelerometer samples (n, 3) in m/s² (x forward, y left, z up; gravity on z) of one stroke."""
    if gesture not in GESTURES:
        raise ValueError(f"gesture '{gesture}' is not one of {', '.join(GESTURES)}")
    n = round(cfg.gesture_duration_s * cfg.accel_rate_hz)
    a = cfg.gesture_peak_mps2
    acc = np.zeros((n, 3))
    if gesture == "circle":  # once round a circle in the y–z plane, from a random start angle
        theta = float(rng.uniform(0.0, 2.0 * math.pi)) + 2.0 * math.pi * (np.arange(n) + 0.5) / n
        direction = np.stack([np.zeros(n), -np.cos(theta), -np.sin(theta)], axis=1)
        acc += a * direction
        acc += a * cfg.cross_axis_leak * rng.standard_normal(3) * _template(n)[:, None]
    else:
        axis, sign = _STROKES[gesture]
        d = cfg.cross_axis_leak * rng.standard_normal(3)
        d[axis] = sign
        acc += a * _template(n)[:, None] * d[None, :]
    acc[:, 2] += _GRAVITY_MPS2
    return acc + cfg.noise_mps2 * rng.standard_normal(acc.shape)


def recognise_gesture(cfg: WatchConfig, samples: np.ndarray) -> str:
    """The gesture of one stroke's samples (n, 3): circle by the energy ratio, else axis and sign."""
    a = samples - samples.mean(axis=0)
    energy = (a**2).sum(axis=0)
    order = np.argsort(energy)[::-1]
    if energy[order[1]] >= cfg.circle_energy_ratio * energy[order[0]]:
        return "circle"
    axis = int(order[0])
    score = float(a[:, axis] @ _template(len(a)))
    return _STROKE_OF[(axis, 1.0 if score > 0.0 else -1.0)]


class Watch:
    """The smart watch: the user performs gestures, the watch recognises them after a delay.

    ``perform(gesture, t)`` starts a stroke at ``t``; ``poll(t)`` returns the commands whose
    recognition finished by ``t`` (each once, in order), to be delivered over BLE by the caller.
    """

    def __init__(self, cfg: WatchConfig, rng: np.random.Generator):
        self.cfg = cfg
        self.rng = rng
        self._pending: list[tuple[float, float, str]] = []  # (recognised_s, performed_s, recognised gesture)
        self._busy_until = -math.inf
        self._last_move: Command | None = None  # last single move delivered, for the combination

    def perform(self, gesture: str, t_s: float) -> None:
        """The user performs ``gesture`` starting at ``t_s`` (s); one stroke at a time."""
        if t_s < self._busy_until - _EPS_S:
            raise ValueError(f"a gesture is still being performed until {self._busy_until:.3f} s; start at or after it")
        recognised = recognise_gesture(self.cfg, gesture_trace(self.cfg, gesture, self.rng))
        self._pending.append((t_s + self.cfg.recognition_delay_s, t_s, recognised))
        self._busy_until = t_s + self.cfg.gesture_duration_s

    def poll(self, t_s: float) -> list[Command]:
        """Commands recognised by ``t_s``, diagonals combined (seed 002 §3.1)."""
        out: list[Command] = []
        while self._pending and self._pending[0][0] <= t_s + _EPS_S:
            recognised_s, performed_s, gesture = self._pending.pop(0)
            cmd = command_of(gesture, performed_s, recognised_s)
            last = self._last_move
            if (
                cmd.kind == "move"
                and last is not None
                and recognised_s - last.recognised_s <= self.cfg.combination_window_s + _EPS_S
            ):
                diagonal = combine(last, cmd)
                if diagonal is not None:
                    out.append(diagonal)
                    self._last_move = None  # a diagonal does not combine further
                    continue
            out.append(cmd)
            self._last_move = cmd if cmd.kind == "move" else None
        return out


# --------------------------------------------------------------------------- remote driver


class RemoteDriver:
    """Remote-control mode: delivered commands → body-frame ``(vx, vy, ω)`` (seed 002 §3.1, Table 1).

    The latest command replaces the one in progress. A move drives at ``remote_speed_mps`` along its
    (possibly diagonal) direction for ``move_duration_s``; Up / Down rotate by ``rotate_angle_deg``
    on the robot's own AHRS yaw, proportional control capped at ``remote_turn_rate_dps``, until
    within ``rotate_tolerance_deg``; Circle cancels. Timers and yaw targets start at the first
    :meth:`command` call after a push (when the robot acts on it).
    """

    def __init__(self, cfg: WatchConfig):
        self.cfg = cfg
        self._active: Command | None = None
        self._start_s: float | None = None
        self._target_yaw: float | None = None

    @property
    def active(self) -> Command | None:
        """The command being executed, None when idle."""
        return self._active

    def push(self, cmd: Command) -> str | None:
        """Take a delivered command. Returns ``"cancel"`` for Circle (back to command-waiting), else None."""
        self._start_s = None
        self._target_yaw = None
        if cmd.kind == "cancel":
            self._active = None
            return "cancel"
        self._active = cmd
        return None

    def command(self, t_s: float, ahrs_yaw_rad: float) -> tuple[float, float, float] | None:
        """Body-frame ``(vx m/s, vy m/s, ω rad/s)`` at ``t_s``, or None when idle (move done, rotation done)."""
        cmd, cfg = self._active, self.cfg
        if cmd is None:
            return None
        if cmd.kind == "move":
            if self._start_s is None:
                self._start_s = t_s
            if t_s - self._start_s >= cfg.move_duration_s - _EPS_S:
                self._active = None
                return None
            dx, dy = cmd.direction
            return (cfg.remote_speed_mps * dx, cfg.remote_speed_mps * dy, 0.0)
        # rotate
        if self._target_yaw is None:
            self._target_yaw = ahrs_yaw_rad + cmd.turn_sign * math.radians(cfg.rotate_angle_deg)
        err = math.remainder(self._target_yaw - ahrs_yaw_rad, 2.0 * math.pi)
        if abs(err) <= math.radians(cfg.rotate_tolerance_deg):
            self._active = None
            return None
        w_max = math.radians(cfg.remote_turn_rate_dps)
        return (0.0, 0.0, max(-w_max, min(w_max, cfg.rotate_gain * err)))
