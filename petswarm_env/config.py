"""Typed, validated configuration.

The values live in one place, ``configs/default.yaml`` (shipped inside the package as
``petswarm_env/default.yaml`` and mirrored at the repository's ``configs/``); this module holds
only their *types and ranges*. A user's file or ``--set`` overrides are merged over the defaults,
then validated as a whole: an unknown key or a bad value raises :class:`ConfigError` whose message
names the key, what is wrong and what is allowed.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from petswarm_env.middleware.ir import IRConfig
from petswarm_env.wearables.lf import LFConfig
from petswarm_env.wearables.belt import BeltConfig
from petswarm_env.wearables.watch import WatchConfig

SCENARIOS = (
    "straight",
    "turn_left_60",
    "turn_right_60",
    "zigzag",
    "u_turn",
    "stop_and_go",
    "random_walk",
    "mode_change",
)
FORMATIONS = ("column", "row", "wedge", "grid", "custom")
DRIVING_MODES = ("following", "leading")


class ConfigError(ValueError):
    """A configuration key or value is wrong; the message says which and how to fix it."""


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BoxObstacle(_Section):
    center_m: tuple[float, float]
    size_m: tuple[float, float] = Field(description="width (x) and height (y)")


class WorldConfig(_Section):
    arena_m: tuple[float, float] = Field(description="walled arena width, height (m); 0 = no walls")
    obstacles: list[BoxObstacle]
    num_users: int = Field(ge=1, le=8, description="users, each with a master, a robot pool and its own PAN")
    user_spacing_m: float = Field(gt=0, description="distance between the users' start positions (along y)")
    collision_slop_m: float = Field(gt=0, description="overlap of two bodies in contact that the physics leaves uncorrected (m; pymunk's collision_slop)")


class UltrasonicConfig(_Section):
    count: int = Field(ge=0, le=32)
    min_range_m: float = Field(ge=0)
    max_range_m: float = Field(gt=0)
    noise_m: float = Field(ge=0)


class RobotConfig(_Section):
    radius_m: float = Field(gt=0)
    mass_kg: float = Field(gt=0)
    max_speed_mps: float = Field(gt=0, description="wheel-limited translation speed")
    max_omega_rps: float = Field(gt=0)
    max_accel_mps2: float = Field(gt=0)
    max_alpha_rps2: float = Field(gt=0)
    wheel_lever_m: float = Field(gt=0, description="lx + ly of the mecanum wheel layout")
    ultrasonic: UltrasonicConfig
    ahrs_noise_deg: float = Field(ge=0)
    ahrs_drift_dps: float = Field(ge=0)
    odometry_noise_rel: float = Field(ge=0)


class CustomLink(_Section):
    robot: int = Field(ge=1, description="member number of the slave")
    neighbour: int = Field(ge=0, description="member number of its reference neighbour (0 = master)")
    offset_m: tuple[float, float] = Field(description="reference offset in the formation frame")


class SwarmConfig(_Section):
    num_slaves: int = Field(ge=1, le=16)
    extra_robots: int = Field(ge=0, le=16, description="waiting robots beyond the required number")
    formation: Literal[FORMATIONS]  # type: ignore[valid-type]
    spacing_m: float = Field(gt=0)
    custom_links: list[CustomLink]
    mode: Literal[DRIVING_MODES]  # type: ignore[valid-type]
    spawn_jitter_m: float = Field(ge=0)
    master_change: bool = Field(description="the user's master-change request on a driving-mode change (Table 3)")
    other_user_robots: int = Field(ge=0, le=16, description="waiting robots already connected to another user")


class RadioConfig(_Section):
    bitrate_bps: float = Field(gt=0)
    frame_overhead_bytes: int = Field(ge=0)
    latency_s: float = Field(ge=0)
    loss_prob: float = Field(ge=0, le=1)
    processing_s: float = Field(ge=0, description="MCU time to handle a frame before replying")
    processing_jitter_s: float = Field(ge=0)
    backoff_slot_s: float = Field(gt=0)
    min_be: int = Field(ge=0, le=8)
    max_be: int = Field(ge=0, le=8)
    max_backoffs: int = Field(ge=0, le=8)
    turnaround_s: float = Field(ge=0, description="CCA-to-TX turnaround: a frame started inside it is not sensed")
    range_m: float = Field(gt=0)
    rssi_shadowing_db: float = Field(ge=0, description="σ of log-normal shadowing on the RSSI")
    path_loss_exponent: float = Field(gt=0)


class ProtocolConfig(_Section):
    join_radius_m: float = Field(gt=0, description="master's available region (seed 000 Table 1)")
    scan_window_s: float = Field(gt=0)
    response_timeout_s: float = Field(gt=0)
    max_retries: int = Field(ge=0)
    organize_timeout_s: float = Field(gt=0)
    ring_response_timeout_s: float = Field(gt=0, description="token holder waits this long for responses")
    ir_tx_s: float = Field(gt=0, description="IR transmission time of one token holder")
    token_timeout_s: float = Field(gt=0, description="master regenerates the token after this silence")
    token_retries: int = Field(ge=0)
    broadcast_period_s: float = Field(gt=0, description="master's speed/activity broadcast")


class UserConfig(_Section):
    scenario: Literal[SCENARIOS]  # type: ignore[valid-type]
    scenario_pool: list[Literal[SCENARIOS]]  # type: ignore[valid-type]
    radius_m: float = Field(gt=0)
    walk_speed_mps: float = Field(gt=0)
    run_speed_mps: float = Field(gt=0)
    turn_rate_dps: float = Field(gt=0)
    start_delay_s: float = Field(ge=0)


class MasterConfig(_Section):
    distance_m: float = Field(gt=0, description="standard distance to the user (seed 000 §3.6.2)")
    acc_band_m: float = Field(ge=0, description="ACC: speed matching inside ±band of the distance, distance control outside")
    distance_gain: float = Field(gt=0, description="distance-control gain outside the band (1/s)")
    speed_gain: float = Field(ge=0, description="distance correction while speed matching (1/s)")
    rotate_gain: float = Field(gt=0, description="ω per rad of heading error beyond the deadband (following: the user's bearing)")
    rotate_deadband_deg: float = Field(ge=0, le=25, description="no rotation (and no leading correction) within ±this (inside the reliable ±25°)")
    sideways_gain: float = Field(gt=0, description="leading: Vy per m of lateral user offset outside ±reliable angle")
    arc_gain: float = Field(ge=0, description="leading: rate (rad/s) at which the robot's place about the user closes on straight ahead, per unit sine of the gap")
    arc_sync_gain: float = Field(gt=0, description="leading: rate (1/s) at which the arc made since a rotation started closes on the belt's accumulated angle")
    arc_sync_done_deg: float = Field(gt=0, description="leading: the rotation's arc is done within this many degrees of the accumulated angle after the rotation ended, its rate below arc_sync_gain times this")
    trail_rps: float = Field(ge=0, description="following: rate (rad/s) at which the robot's place about the walking user drifts in behind them, per unit sine of the gap")
    heading_blend_rps: float = Field(gt=0, description="the user's walking direction is pulled toward the LF track's at this rate (1/s); the belt's rotation turns it at once")
    walk_speed_mps: float = Field(gt=0, description="tracked speed below which the user stands; along the line of sight above it, a walk that the belt has not recognised yet")
    tracker_alpha: float = Field(gt=0, le=1, description="LF-fix tracker position gain")
    tracker_beta: float = Field(ge=0, le=2, description="LF-fix tracker velocity gain")
    lost_user_s: float = Field(gt=0, description="no LF fix for this long -> emergency (seed 002 Fig. 4)")
    exception_range_m: float = Field(gt=0, description="leading: obstacle closer than this in the travel direction -> exception")


class ControlConfig(_Section):
    safety_layer: bool = Field(description="the ultrasonic safety stage of the control arbiter (seed 001)")
    safety_stop_m: float = Field(gt=0, description="brake before this ultrasonic range: speed toward an obstacle ≤ √(2a(range − this))")
    safety_backoff_mps: float = Field(ge=0, description="back-away speed when closer than half the stop range")


class BLEConfig(_Section):
    latency_s: float = Field(ge=0, description="one BLE message, wearable <-> robot")
    connect_s: float = Field(ge=0, description="BLE connection set-up after the belt woke up or a handover")
    report_period_s: float = Field(gt=0, description="belt -> robot reports (activity, rotation)")


class RewardConfig(_Section):
    formation: float
    heading: float
    collision: float
    smoothness: float


class RenderConfig(_Section):
    fps: int = Field(gt=0)
    pixels_per_m: float = Field(gt=0)
    size_px: tuple[int, int]


class Config(_Section):
    seed: int = Field(ge=0)
    max_cycles: int = Field(gt=0)
    control_period_s: float = Field(gt=0)
    physics_substeps: int = Field(ge=1, le=100)
    world: WorldConfig
    robot: RobotConfig
    swarm: SwarmConfig
    radio: RadioConfig
    protocol: ProtocolConfig
    ir: IRConfig
    lf: LFConfig
    user: UserConfig
    belt: BeltConfig
    watch: WatchConfig
    master: MasterConfig
    control: ControlConfig
    ble: BLEConfig
    reward: RewardConfig
    render: RenderConfig

    @model_validator(mode="after")
    def _check_consistency(self) -> Config:
        if self.radio.max_be < self.radio.min_be:
            raise ValueError("radio.max_be must be >= radio.min_be")
        if self.swarm.formation == "custom" and not self.swarm.custom_links:
            raise ValueError("swarm.formation 'custom' needs swarm.custom_links (robot, neighbour, offset_m)")
        return self

    def to_dict(self) -> dict[str, Any]:
        return self.model_dump(mode="json")


def default_config_path() -> Path:
    return Path(str(resources.files("petswarm_env") / "default.yaml"))


def read_yaml(path: str | Path) -> dict[str, Any]:
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"config file '{path}' does not exist; pass an existing YAML file")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"config file '{path}' is not valid YAML: {exc}".replace("\n", " ")) from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"config file '{path}' must hold a mapping of keys, got {type(data).__name__}")
    return data


def merge_mappings(base: dict[str, Any], over: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out = copy.deepcopy(base)
    for key, value in over.items():
        dotted = f"{prefix}{key}"
        if key not in out:
            allowed = ", ".join(sorted(out)) if out else "(none)"
            raise ConfigError(f"unknown config key '{dotted}'; allowed keys here: {allowed}")
        if isinstance(out[key], dict) and isinstance(value, Mapping):
            out[key] = merge_mappings(out[key], value, prefix=f"{dotted}.")
        else:
            out[key] = copy.deepcopy(value)
    return out


def flatten_dotted(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"swarm": {"num_slaves": 4}}`` -> ``{"swarm.num_slaves": 4}`` (lists stay values)."""
    out: dict[str, Any] = {}
    for key, value in d.items():
        if isinstance(value, Mapping):
            out.update(flatten_dotted(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def parse_override(item: str) -> tuple[str, Any]:
    """Parse ``KEY=VALUE`` (VALUE read as YAML, so ``3``, ``0.1``, ``true``, ``[1, 2]`` work)."""
    if "=" not in item:
        raise ConfigError(f"override '{item}' must look like KEY=VALUE, e.g. swarm.num_slaves=3")
    key, raw = item.split("=", 1)
    try:
        value = yaml.safe_load(raw)
    except yaml.YAMLError:
        value = raw
    return key.strip(), value


def nest_dotted(overrides: Mapping[str, Any]) -> dict[str, Any]:
    nested: dict[str, Any] = {}
    for key, value in overrides.items():
        parts = key.split(".")
        node = nested
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ConfigError(f"override '{key}' conflicts with another override of '{part}'")
        node[parts[-1]] = value
    return nested


def format_validation_error(exc: ValidationError) -> str:
    err = exc.errors()[0]
    loc = ".".join(str(p) for p in err["loc"]) or "(config)"
    msg = err["msg"]
    if err["type"] == "extra_forbidden":
        return f"unknown config key '{loc}'"
    if not err["loc"]:  # a rule across keys (model validator): the message names the keys
        return f"bad config: {msg.removeprefix('Value error, ')}"
    return f"bad config value for '{loc}': {msg} (got {err.get('input')!r})"


def load_config(
    path: str | Path | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> Config:
    """Load the defaults, merge a user YAML file and dotted overrides over them, validate.

    ``overrides`` maps dotted keys (``"swarm.num_slaves"``) or top-level sections (``"swarm":
    {...}``) to values. Raises :class:`ConfigError` with a one-line reason on any problem.
    """
    data = read_yaml(default_config_path())
    if path is not None:
        data = merge_mappings(data, read_yaml(path))
    if overrides:
        data = merge_mappings(data, nest_dotted(overrides))
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc)) from None
