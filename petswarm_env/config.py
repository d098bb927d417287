"""Typed, validated configuration.

The values live in one place, ``configs/default.yaml`` (shipped inside the package as
``petswarm/configs/default.yaml``; one file, the repository's ``configs/default.yaml``); this module holds
only their *types and ranges*. A user's file or ``--set`` overrides are merged over the defaults,
then validated as a whole: an unknown key or a bad value raises :class:`ConfigError` whose message
names the key, what is wrong and what is allowed.
"""

from __future__ import annotations

import copy
import functools
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, Field, ValidationError, model_validator
from pydantic_core import PydanticCustomError

from petswarm_env.config_base import (ACCEL_MPS2, ADC_MAX, COUNT, EPISODE_S, FAR_M, FAST_MPS, GAIN, LEVEL_DB, LONG_S,
                                      MASS_KG, MAX_CYCLES, MAX_LIST, NEAR_M, REL, SHORT_M, SPIN_DPS, SPIN_RPS, TICK_S,
                                      WEIGHT, ConfigError, Section, describe_value, format_validation_error)
from petswarm_env.config_yaml import (flatten_dotted, merge_mappings, nest_dotted, parse_override, parse_yaml,  # noqa: F401
                                      read_yaml)  # the bounded YAML reader and the merging of overrides, re-exported
from petswarm_env.config_wearables import BeltConfig, LFConfig, WatchConfig  # noqa: F401  (re-exported)
from petswarm_env.config_runtime import FAULT_KINDS, ArrivalSpec, FaultSpec, FaultsRandomConfig, SuccessionConfig  # noqa: F401
from petswarm_env.config_base import Section  # noqa: F401  (the base of every section; re-exported here)
from petswarm_env.robot_types import PoolEntry, RobotTypeConfig, max_pool_size, robot_types_problem
from petswarm_env.scenarios import SCENARIOS  # the registry (the scenarios import nothing of the package)

# (Section and the runtime-change types are imported here for the modules that import them from this one)


FORMATIONS = ("column", "row", "wedge", "grid", "custom")
DRIVING_MODES = ("following", "leading")
ASSIGNMENTS = ("closest", "ruta_centralized", "ruta_decentralized")  # swarm.assignment (middleware/assignment.py)
SPAWN_MODES = ("scattered", "at_slots")  # where the waiting robots start (petswarm_env/scenarios/base.py: Scenario.place)


def _registered_scenario(name: str) -> str:
    """A scenario name must be in the registry at validation time (so a scenario registered after
    this module was imported is a choice too); the error lists the choices, as a Literal's would."""
    if name not in SCENARIOS:
        names = [repr(n) for n in SCENARIOS]
        choices = f"{', '.join(names[:-1])} or {names[-1]}" if len(names) > 1 else "".join(names)
        raise PydanticCustomError("literal_error", "Input should be {choices}", {"choices": choices})
    return name


ScenarioName = Annotated[str, AfterValidator(_registered_scenario)]


# the memory an episode may take: its recorded trajectories (evaluation/runner.py: x, y and heading
# of every robot and user per step, float64) must fit this budget; every other allocation the config
# sizes (the LF table, the belt's windows, a rendered frame) is bounded by its fields' ranges alone
MEMORY_BUDGET_BYTES = 1_000_000_000
RECORD_BYTES_PER_BODY_STEP = 3 * 8

Distance = Annotated[float, Field(ge=-FAR_M, le=FAR_M)]  # a coordinate or an offset within the largest arena
Size = Annotated[float, Field(ge=0, le=FAR_M)]  # a width or a height within the largest arena
Offset = Annotated[float, Field(ge=-NEAR_M, le=NEAR_M)]  # a formation offset within sensing distance


class BoxObstacle(Section):
    center_m: tuple[Distance, Distance]
    size_m: tuple[Size, Size] = Field(description="width (x) and height (y)")


class WorldConfig(Section):
    arena_m: tuple[Size, Size] = Field(description="walled arena width, height (m); 0 = no walls")
    obstacles: list[BoxObstacle] = Field(max_length=MAX_LIST)
    num_users: int = Field(ge=1, le=8, description="users, each with a master, a robot pool and its own PAN")
    user_spacing_m: float = Field(gt=0, le=FAR_M, description="distance between the users' start positions (along y)")
    collision_slop_m: float = Field(gt=0, le=1.0, description="overlap of two bodies in contact that the physics leaves uncorrected (m; pymunk's collision_slop)")

    @model_validator(mode="after")
    def _check_arena(self) -> WorldConfig:
        w, h = self.arena_m
        if w < 0 or h < 0 or (w == 0) != (h == 0):
            raise ValueError(f"world.arena_m must be [0, 0] (no walls) or a width and a height > 0 m, got [{w:g}, {h:g}]")
        for i, box in enumerate(self.obstacles):
            (cx, cy), (bw, bh) = box.center_m, box.size_m
            if bw <= 0 or bh <= 0:
                raise ValueError(f"world.obstacles[{i}].size_m must be a width and a height > 0 m, got [{bw:g}, {bh:g}]")
            if w > 0 and (abs(cx) + bw / 2 > w / 2 or abs(cy) + bh / 2 > h / 2):
                raise ValueError(
                    f"world.obstacles[{i}] (centre [{cx:g}, {cy:g}], size [{bw:g}, {bh:g}] m) reaches outside the "
                    f"{w:g} x {h:g} m arena (world.arena_m, centred on the origin); move the box or make the arena larger")
        return self


class UltrasonicConfig(Section):
    count: int = Field(ge=0, le=32)
    min_range_m: float = Field(ge=0, le=NEAR_M)
    max_range_m: float = Field(gt=0, le=NEAR_M)
    noise_m: float = Field(ge=0, le=NEAR_M)

    @model_validator(mode="after")
    def _check_ranges(self) -> UltrasonicConfig:
        if self.min_range_m >= self.max_range_m:
            raise ValueError(f"robot.ultrasonic.min_range_m ({self.min_range_m:g}) must be less than "
                             f"robot.ultrasonic.max_range_m ({self.max_range_m:g})")
        return self


class RobotConfig(Section):
    radius_m: float = Field(ge=0.01, le=5.0)
    mass_kg: float = Field(gt=0, le=MASS_KG)
    max_speed_mps: float = Field(gt=0, le=FAST_MPS, description="wheel-limited translation speed")
    max_omega_rps: float = Field(gt=0, le=SPIN_RPS)
    max_accel_mps2: float = Field(gt=0, le=ACCEL_MPS2)
    max_alpha_rps2: float = Field(gt=0, le=10 * ACCEL_MPS2)
    wheel_lever_m: float = Field(ge=SHORT_M, le=10.0, description="lx + ly of the mecanum wheel layout")
    ultrasonic: UltrasonicConfig
    ahrs_noise_deg: float = Field(ge=0, le=180)
    ahrs_drift_dps: float = Field(ge=0, le=SPIN_DPS)
    odometry_noise_rel: float = Field(ge=0, le=REL)
    clock_drift_ppm: float = Field(ge=0, le=1000.0, description="each MCU clock's drift is drawn within ± this (ppm)")
    clock_offset_max_s: float = Field(ge=0, le=1e6, description="each MCU clock's offset is drawn in [0, this) s")


class CustomLink(Section):
    robot: int = Field(ge=1, le=32, description="member number of the slave")
    neighbour: int = Field(ge=0, le=32, description="member number of its reference neighbour (0 = master)")
    offset_m: tuple[Offset, Offset] = Field(description="reference offset in the formation frame")


class SwarmConfig(Section):
    num_slaves: int = Field(ge=1, le=16)
    extra_robots: int = Field(ge=0, le=16, description="waiting robots beyond the required number")
    spares: int = Field(0, ge=0, le=15, description="robots recruited beyond num_slaves, walking on the shape's next slots (middleware/join.py)")
    formation: Literal[FORMATIONS]  # type: ignore[valid-type]
    spacing_m: float = Field(ge=0.01, le=NEAR_M)
    custom_links: list[CustomLink] = Field(max_length=32)
    mode: Literal[DRIVING_MODES]  # type: ignore[valid-type]
    spawn: Literal[SPAWN_MODES] = Field(description="scattered: waiting robots start anywhere in the master's available region, "  # type: ignore[valid-type]
                                        "random headings; at_slots: within spawn_jitter_m of their formation slots")
    spawn_jitter_m: float = Field(ge=0, le=NEAR_M)
    master_change: bool = Field(description="the user's master-change request on a driving-mode change (Table 3)")
    other_user_robots: int = Field(ge=0, le=16, description="waiting robots already connected to another user")
    assignment: Literal[ASSIGNMENTS] = Field(description="who joins and which slot each member takes: closest (seed 000 "  # type: ignore[valid-type]
                                             "Table 2), ruta_centralized (seed 003 Algorithm 1), ruta_decentralized (Algorithm 2)")
    pool: list[PoolEntry] = Field(description="each user's waiting robots by type; empty = num_slaves + extra_robots petbots")


class RadioConfig(Section):
    bitrate_bps: float = Field(ge=1e3, le=1e9)
    frame_overhead_bytes: int = Field(ge=0, le=127)
    latency_s: float = Field(ge=0, le=10.0)
    loss_prob: float = Field(ge=0, le=1)
    processing_s: float = Field(ge=0, le=10.0, description="MCU time to handle a frame before replying")
    processing_jitter_s: float = Field(ge=0, le=10.0)
    backoff_slot_s: float = Field(ge=1e-5, le=1.0)
    min_be: int = Field(ge=0, le=8)
    max_be: int = Field(ge=0, le=8)
    max_backoffs: int = Field(ge=0, le=8)
    turnaround_s: float = Field(ge=0, le=1.0, description="CCA-to-TX turnaround: a frame started inside it is not sensed")
    range_m: float = Field(gt=0, le=FAR_M)
    rssi_shadowing_db: float = Field(ge=0, le=LEVEL_DB, description="σ of log-normal shadowing on the RSSI")
    path_loss_exponent: float = Field(ge=1.0, le=10.0)


class ProtocolConfig(Section):
    join_radius_m: float = Field(gt=0, le=NEAR_M, description="master's available region (seed 000 Table 1)")
    scan_window_s: float = Field(ge=TICK_S, le=LONG_S)
    response_timeout_s: float = Field(ge=TICK_S, le=LONG_S)
    max_retries: int = Field(ge=0, le=COUNT)
    organize_timeout_s: float = Field(ge=TICK_S, le=LONG_S)
    ring_response_timeout_s: float = Field(ge=TICK_S, le=LONG_S, description="token holder waits this long for responses")
    ir_tx_s: float = Field(ge=TICK_S, le=LONG_S, description="IR transmission time of one token holder")
    ring_answer_slot_s: float = Field(ge=0, le=1.0, description="a crowded ring's members answer a start sign in member order, this far apart (middleware/token_ring.py)")
    ring_ir_tx_crowded_s: float = Field(ge=TICK_S, le=LONG_S, description="IR transmission time of one token holder in a crowded ring (middleware/token_ring.py)")
    replan_min_slaves: int = Field(ge=1, le=COUNT, description="from this many slaves the master re-plans the slots by its IR fixes after the ring's first round (middleware/join.py)")
    token_timeout_s: float = Field(ge=TICK_S, le=LONG_S, description="master regenerates the token after this silence")
    token_retries: int = Field(ge=0, le=COUNT)
    broadcast_period_s: float = Field(ge=TICK_S, le=LONG_S, description="master's speed/activity broadcast")
    lost_after_rounds: int = Field(ge=1, le=COUNT, description="a member the master heard nothing from in this many ring rounds is lost")
    status_timeout_s: float = Field(ge=TICK_S, le=LONG_S, description="a slave that heard no status broadcast this long stops and returns to waiting")
    rescan_period_s: float = Field(ge=TICK_S, le=LONG_S, description="the organized master scans for waiting robots this often while a slot is open")


class RutaConfig(Section):
    """Seed 003 RUTA on the swarm (middleware/assignment.py); used only with swarm.assignment ruta_*."""

    t_m_s: float = Field(ge=TICK_S, le=EPISODE_S, description="t_m: total time given to a robot for its subtasks (seed 003 §5.2.1: 200 s)")
    u1_per_s: float = Field(gt=0, le=GAIN, description="u1 of the priority (seed 003 §5.2.1: 0.01)")
    u2: float = Field(gt=0, le=WEIGHT, description="u2 of the utility (seed 003 §5.2.1: 1)")
    min_distance_m: float = Field(ge=SHORT_M, le=NEAR_M, description="distances below count as this (d^(-1/2) diverges at 0)")
    max_trials: int = Field(ge=1, le=100, description="Algorithm 1's K (passes of steps 1-9)")
    bid_timeout_s: float = Field(ge=TICK_S, le=LONG_S, description="Algorithm 2's t_out: the announcer waits this long for bids")
    bid_slot_s: float = Field(ge=0, le=1.0, description="the k-th listed bidder bids k x this after the announcement (fewer collisions)")
    max_announcements: int = Field(ge=1, le=20, description="announcements of one open slot before it stays unfilled")


class UserConfig(Section):
    scenario: ScenarioName
    scenario_pool: list[ScenarioName] = Field(max_length=MAX_LIST)
    radius_m: float = Field(ge=0.05, le=2.0)
    walk_speed_mps: float = Field(gt=0, le=FAST_MPS)
    run_speed_mps: float = Field(gt=0, le=FAST_MPS)
    turn_rate_dps: float = Field(gt=0, le=SPIN_DPS)
    start_delay_s: float = Field(ge=0, le=LONG_S)
    formation_wait_s: float = Field(ge=0, le=LONG_S, description=(
        "the user stands until the formation is built (every slave within metrics.BUILT_WITHIN_M of its reference "
        "and heading within metrics.BUILT_FACING_RAD of its master's), at most this long after organizing; "
        "start_delay_s is the least stand"))

    @model_validator(mode="after")
    def _check_speeds(self) -> UserConfig:
        if self.run_speed_mps < self.walk_speed_mps:
            raise ValueError(f"user.run_speed_mps ({self.run_speed_mps:g}) must be at least user.walk_speed_mps "
                             f"({self.walk_speed_mps:g})")
        return self


class MasterConfig(Section):
    distance_m: float = Field(gt=0, le=NEAR_M, description="standard distance to the user (seed 000 §3.6.2)")
    acc_band_m: float = Field(ge=0, le=NEAR_M, description="ACC: speed matching inside ±band of the distance, distance control outside")
    distance_gain: float = Field(gt=0, le=GAIN, description="distance-control gain outside the band (1/s)")
    speed_gain: float = Field(ge=0, le=GAIN, description="distance correction while speed matching (1/s)")
    rotate_gain: float = Field(gt=0, le=GAIN, description="ω per rad of heading error beyond the deadband (following: the user's bearing)")
    rotate_deadband_deg: float = Field(ge=0, le=25, description="no rotation (and no leading correction) within ±this (inside the reliable ±25°)")
    sideways_gain: float = Field(gt=0, le=GAIN, description="leading: Vy per m of lateral user offset outside ±reliable angle")
    arc_gain: float = Field(ge=0, le=GAIN, description="leading: rate (rad/s) at which the robot's place about the user closes on straight ahead, per unit sine of the gap")
    arc_sync_gain: float = Field(gt=0, le=GAIN, description="leading: rate (1/s) at which the arc made since a rotation started closes on the belt's accumulated angle")
    arc_sync_done_deg: float = Field(gt=0, le=180, description="leading: the rotation's arc is done within this many degrees of the accumulated angle after the rotation ended, its rate below arc_sync_gain times this")
    arc_brake_mps2: float = Field(gt=0, le=ACCEL_MPS2, description="leading: the deceleration the rotation's arc plans with: never faster than it can stop within the rest of the accumulated angle")
    trail_rps: float = Field(ge=0, le=SPIN_RPS, description="following: rate (rad/s) at which the robot's place about the walking user drifts in behind them, per unit sine of the gap")
    heading_blend_rps: float = Field(gt=0, le=GAIN, description="the user's walking direction is pulled toward the LF track's at this rate (1/s); the belt's rotation turns it at once")
    walk_speed_mps: float = Field(gt=0, le=FAST_MPS, description="tracked speed below which the user stands; along the line of sight above it, a walk that the belt has not recognised yet")
    tracker_alpha: float = Field(gt=0, le=1, description="LF-fix tracker position gain")
    tracker_beta: float = Field(ge=0, le=2, description="LF-fix tracker velocity gain")
    lost_user_s: float = Field(ge=TICK_S, le=LONG_S, description="no LF fix for this long -> emergency (seed 002 Fig. 4)")
    exception_range_m: float = Field(gt=0, le=NEAR_M, description="leading: obstacle closer than this in the travel direction -> exception")


class ControlConfig(Section):
    safety_layer: bool = Field(description="the ultrasonic safety stage of the control arbiter (seed 001)")
    safety_stop_m: float = Field(gt=0, le=NEAR_M, description="brake before this ultrasonic range: speed toward an obstacle ≤ √(2a(range − this))")
    safety_backoff_mps: float = Field(ge=0, le=FAST_MPS, description="back-away speed when closer than half the stop range")


class BLEConfig(Section):
    latency_s: float = Field(ge=0, le=4.0, description="one BLE message, wearable <-> robot")
    connect_s: float = Field(ge=0, le=LONG_S, description="BLE connection set-up after the belt woke up or a handover")
    report_period_s: float = Field(ge=7.5e-3, le=LONG_S, description="belt -> robot reports (activity, rotation)")
    supervision_timeout_s: float = Field(ge=TICK_S, le=LONG_S, description="the belt drops a link that carried no packet of its robot this long")


Weight = Annotated[float, Field(ge=-WEIGHT, le=WEIGHT)]  # a reward weight: the reward stays finite in float32


class RewardConfig(Section):
    formation: Weight
    heading: Weight
    collision: Weight
    smoothness: Weight


class RenderConfig(Section):
    fps: int = Field(ge=1, le=240)
    pixels_per_m: float = Field(ge=1e-3, le=1e4)
    size_px: tuple[int, int]  # 1..8192 each (_check_size): a frame is at most 8192 x 8192 x 3 bytes = 201 MB

    @model_validator(mode="after")
    def _check_size(self) -> RenderConfig:
        if min(self.size_px) < 1 or max(self.size_px) > 8192:
            raise ValueError(f"render.size_px must be a width and a height from 1 to 8192 pixels, got {list(self.size_px)}")
        return self


class IRConfig(Section):
    """The IR relative-location module (seed 000 §3.3; calibrated to Table 4)."""

    num_receivers: int = Field(ge=7, le=64, description=(
        "Phototransistors in the ring, equally spaced, receiver 0 at the robot's front, numbered counter-clockwise. "
        "At least 7, so that both side neighbours of the strongest receiver stay inside the front half of the lobe "
        "(spacing < 60°)."))
    strength_at_1m: float = Field(gt=0, le=ADC_MAX, description="Received strength on a receiver's axis with the source at 1 m, ADC units.")
    lobe_exponent: float = Field(gt=0, le=100.0, description=(
        "Angular response of one receiver, max(0, cos(Δ))**lobe_exponent for a source Δ rad off its axis. "
        "The estimator assumes 1; the hardware is modelled with a different value."))
    noise_rel: float = Field(ge=0, le=REL, description="σ of the multiplicative Gaussian noise on each receiver, fraction of the signal.")
    noise_abs: float = Field(ge=0, le=ADC_MAX, description="σ of the additive Gaussian noise on each receiver, ADC units.")
    saturation: float = Field(gt=0, le=1e12, description="ADC ceiling, ADC units; readings are clipped to [0, saturation]. At most 1e12: a receiver that never saturates (the estimator's ideal); a real ADC has 10-24 bits")
    detect_threshold: float = Field(gt=0, le=ADC_MAX, description="Strongest reading below this (ADC units) means no detection.")
    occlusion_attenuation: float = Field(ge=0, le=1, description="Factor on the optical signal when a body blocks the line of sight.")
    max_range_m: float = Field(gt=0, le=NEAR_M, description="Sources farther than this (m) contribute no signal, only receiver noise.")

    @model_validator(mode="after")
    def _check_levels(self) -> IRConfig:
        if self.detect_threshold >= self.saturation:
            raise ValueError(f"ir.detect_threshold ({self.detect_threshold:g}) must be below ir.saturation "
                             f"({self.saturation:g}), the ADC ceiling, or nothing is ever detected")
        return self

    @property
    def spacing_rad(self) -> float:
        """Angle between neighbouring receivers, rad."""
        return 2.0 * math.pi / self.num_receivers


class Config(Section):
    seed: int = Field(ge=0, le=2**63 - 1)
    max_cycles: int = Field(gt=0, le=MAX_CYCLES)
    control_period_s: float = Field(ge=TICK_S, le=1.0)
    physics_substeps: int = Field(ge=1, le=100)
    world: WorldConfig
    robot: RobotConfig
    robot_types: dict[str, RobotTypeConfig] = Field(max_length=64)
    swarm: SwarmConfig
    radio: RadioConfig
    protocol: ProtocolConfig
    ruta: RutaConfig
    ir: IRConfig
    lf: LFConfig
    user: UserConfig
    belt: BeltConfig
    watch: WatchConfig
    master: MasterConfig
    control: ControlConfig
    ble: BLEConfig
    succession: SuccessionConfig
    reward: RewardConfig
    render: RenderConfig
    faults: list[FaultSpec] = Field(max_length=MAX_LIST)
    faults_random: FaultsRandomConfig
    arrivals: list[ArrivalSpec] = Field(max_length=32)  # robot ids beyond the pool; a swarm has at most 16 slaves

    def robot_count(self, arrivals: int | None = None) -> int:
        """Robots in the world: every user's master and pool, the other user's robots, the arrivals
        (``arrivals``: how many; the config's by default)."""
        per_user = 1 + max_pool_size(self)  # the master and its pool (swarm.pool, a scenario's, or num_slaves + extra_robots)
        extra = len(self.arrivals) if arrivals is None else arrivals
        return self.world.num_users * per_user + self.swarm.other_user_robots + extra

    @model_validator(mode="after")
    def _check_consistency(self) -> Config:
        n = self.robot_count()
        episode_s = self.max_cycles * self.control_period_s
        if episode_s > EPISODE_S:
            raise ValueError(f"max_cycles x control_period_s is {episode_s:g} s of simulated time, more than the {EPISODE_S:g} s "
                             "(a day) an episode may last; lower max_cycles")
        record = self.max_cycles * (n + self.world.num_users) * RECORD_BYTES_PER_BODY_STEP
        if record > MEMORY_BUDGET_BYTES:
            raise ValueError(f"an episode of max_cycles={self.max_cycles} steps with {n} robots would record "
                             f"{record / 1e9:.1f} GB of trajectories, more than the {MEMORY_BUDGET_BYTES / 1e9:g} GB budget; "
                             "lower max_cycles or the number of robots")
        for i, f in enumerate(self.faults):
            if isinstance(f.robot, int) and f.robot >= n:
                raise ValueError(f"faults[{i}].robot {f.robot} is not a robot index (this config has robots 0..{n - 1}); "
                                 "give an index below it, 'master' or 'random_slave'")
        if self.master.distance_m <= (touching := self.user.radius_m + self.robot.radius_m):  # inside the user (seed 000 §3.6.2: 1 m)
            raise ValueError(f"master.distance_m ({self.master.distance_m:g} m) must exceed user.radius_m + robot.radius_m ({touching:g} m)")
        if self.radio.max_be < self.radio.min_be:
            raise ValueError(f"radio.max_be ({self.radio.max_be}) must be at least radio.min_be ({self.radio.min_be})")
        if self.control.safety_stop_m >= self.robot.ultrasonic.max_range_m:
            raise ValueError(f"control.safety_stop_m ({self.control.safety_stop_m:g}) must be less than "
                             f"robot.ultrasonic.max_range_m ({self.robot.ultrasonic.max_range_m:g}): the ring must see "
                             "an obstacle before the robot has to stop")
        if self.swarm.formation == "custom" and not self.swarm.custom_links:
            raise ValueError("swarm.formation 'custom' needs swarm.custom_links (robot, neighbour, offset_m)")
        if self.swarm.spares and (self.swarm.formation == "custom" or self.swarm.num_slaves + self.swarm.spares > 16):
            raise ValueError(f"swarm.spares={self.swarm.spares} needs a standard formation (a custom table fixes the size) and swarm.num_slaves + swarm.spares <= 16; lower swarm.spares")
        if self.swarm.formation == "custom":
            named, want = sorted({lk.robot for lk in self.swarm.custom_links}), list(range(1, self.swarm.num_slaves + 1))
            if named != want:
                raise ValueError(f"swarm.custom_links names members {named} but swarm.num_slaves={self.swarm.num_slaves} "
                                 f"makes members {want}: give each slave's links (robot 1..{self.swarm.num_slaves}) or "
                                 f"set swarm.num_slaves={len(named)}")
            problem = _custom_links_problem(self.swarm)
            if problem:
                raise ValueError(problem)
        problem = robot_types_problem(self)
        if problem:
            raise ValueError(problem)
        for i, a in enumerate(self.arrivals):
            if a.type not in self.robot_types:
                raise ValueError(f"arrivals[{i}].type {a.type!r} is not a robot type; use one of {', '.join(self.robot_types)} "
                                 "(robot_types)")
        return self

    def to_dict(self) -> dict[str, Any]:
        return self.model_dump(mode="json")


def _custom_links_problem(swarm: SwarmConfig) -> str | None:
    """Why the custom formation's links cannot place every member (None if they can): a member is
    placed once every neighbour it links to is (middleware/formation.py places them so, outward from
    the master, member 0), so a link to itself, to no member, or a cycle leaves members unplaced."""
    n = swarm.num_slaves
    needs: dict[int, set[int]] = {}
    for i, link in enumerate(swarm.custom_links):
        if link.neighbour == link.robot or link.neighbour > n:
            return (f"swarm.custom_links[{i}]: member {link.robot} refers to invalid neighbour {link.neighbour} "
                    f"({'itself' if link.neighbour == link.robot else 'not a member'}); give a neighbour from 0 (the master) to {n}")
        needs.setdefault(link.robot, set()).add(link.neighbour)
    placed = {0}
    while True:
        ready = [m for m, ns in needs.items() if m not in placed and ns <= placed]
        if not ready:
            break
        placed.update(ready)
    unplaced = sorted(set(needs) - placed)
    if unplaced:
        return (f"swarm.custom_links: the links do not reach the master (member 0) from members {unplaced}: a cycle, "
                "or a neighbour that is itself not reached; link one of them to neighbour 0")
    return None


def arrival_slots(cfg: Config) -> int:
    """How many arrival robots a world of ``cfg`` holds (petswarm_env/runtime.py): the config's
    arrivals, or, when it lists none, the most any of its scenarios brings."""
    if cfg.arrivals:
        return len(cfg.arrivals)
    names = dict.fromkeys((*cfg.user.scenario_pool, cfg.user.scenario))
    return max((len(SCENARIOS[n].arrivals) for n in names), default=0)


@functools.lru_cache(maxsize=1)
def _default_values() -> dict[str, Any]:
    return read_yaml(default_config_path())


def _defaults() -> dict[str, Any]:
    """The default values (the package's default.yaml, parsed once per process: PyYAML takes tens
    of milliseconds for it, and grids and tests load thousands of configs), a fresh copy each call."""
    return copy.deepcopy(_default_values())


def default_config_path() -> Path:
    from petswarm import shipped_configs

    return shipped_configs() / "default.yaml"


def load_config(
    path: str | Path | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> Config:
    """Load the defaults, merge a user YAML file and dotted overrides over them, validate.

    ``overrides`` maps dotted keys (``"swarm.num_slaves"``) or top-level sections (``"swarm":
    {...}``) to values. Raises :class:`ConfigError` with a one-line reason on any problem.
    """
    if path is not None and not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"config must be a Config, the path of a YAML file or None, got {describe_value(path)}")
    if overrides is not None and not isinstance(overrides, Mapping):
        raise TypeError(f"config overrides must be a mapping of dotted keys to values, got {describe_value(overrides)}")
    data = _defaults()
    user: dict[str, Any] = {}
    if path is not None:
        user = read_yaml(path)
        try:
            data = merge_mappings(data, user)
        except ConfigError as exc:
            raise ConfigError(f"{exc} (in config file '{path}')") from None
    nested = nest_dotted(overrides) if overrides else {}
    if nested:
        data = merge_mappings(data, nested)
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        message = format_validation_error(exc, Config)
        loc = exc.errors()[0]["loc"]
        if path is not None and (_holds_key(user, loc) or not _holds_key(nested, loc)):
            message += f" (in config file '{path}')"
        raise ConfigError(message) from None


def _holds_key(data: Any, loc: tuple) -> bool:
    """Whether the nested ``data`` gives the value at ``loc`` (a pydantic location; empty: no)."""
    if not loc:
        return False
    for part in loc:
        if isinstance(data, Mapping) and part in data:
            data = data[part]
        elif isinstance(data, list) and isinstance(part, int) and part < len(data):
            data = data[part]
        else:
            return False
    return True
