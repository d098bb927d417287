"""The wearables' configuration sections: the master's LF localisation (seed 002 §3.2–3.3), the
user's belt and watch (seed 002 §2). Re-exported by :mod:`petswarm_env.config`."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from petswarm_env.config_base import (ACCEL_MPS2, COUNT, FAST_MPS, GAIN, LEVEL_DB, LONG_S, NEAR_M, RATE_HZ, REL, SHORT_M, SPIN_DPS, TICK_S, Section)


class LFConfig(Section):
    """LF wake-up and localisation (seed 002 §3.2–3.3)."""

    antenna_spacing_m: float = Field(ge=SHORT_M, le=10.0, description="dw: distance between the two transmit antennas, m.")
    antenna_forward_m: float = Field(ge=-10.0, le=10.0, description="Forward offset of the antenna midpoint from the robot's centre (body +x), m.")
    burst_period_s: float = Field(ge=0.01, le=LONG_S, description="Localisation bursts while leading/following, s.")
    wake_period_s: float = Field(ge=0.01, le=60.0, description="Wake-up bursts while waiting for a user, s.")
    wake_range_m: float = Field(gt=0, le=NEAR_M, description="A belt within this distance receives the wake-up burst, m.")
    reliable_range_m: float = Field(gt=0, le=NEAR_M, description="Location is reliable within this distance, m.")
    reliable_half_angle_deg: float = Field(gt=0, lt=90, description="Location is reliable within ± this angle of the robot's forward axis, deg.")
    rssi_at_1m_db: float = Field(ge=-LEVEL_DB, le=LEVEL_DB, description="Noiseless RSSI at 1 m from an antenna, dB (receiver scale).")
    falloff_db_per_decade: float = Field(ge=1.0, le=LEVEL_DB, description="RSSI fall-off per decade of distance, dB (near-field magnetic dipole: 60).")
    sensitivity_db: float = Field(ge=-LEVEL_DB, le=LEVEL_DB, description="Carriers weaker than this RSSI level are not received, dB.")
    noise_common_db: float = Field(ge=0, le=LEVEL_DB, description="σ of the Gaussian RSSI error shared by both readings of one burst, dB.")
    noise_antenna_db: float = Field(ge=0, le=LEVEL_DB, description="σ of the independent Gaussian error per reading, dB.")
    rssi_step_db: float = Field(ge=0, le=LEVEL_DB, description="RSSI register quantisation step, dB (0 = none).")
    distortion_loss_db_per_deg: float = Field(ge=0, le=10.0, description="Loss on the far-side antenna per degree of bearing beyond the reliable half-angle, dB/deg.")
    distortion_noise_db_per_deg: float = Field(ge=0, le=10.0, description="Extra σ per reading per degree of bearing beyond the reliable half-angle, dB/deg.")
    table_min_m: float = Field(ge=SHORT_M, le=NEAR_M, description="First distance of the RSSI→distance table, m.")
    table_max_m: float = Field(ge=SHORT_M, le=NEAR_M, description="Last distance of the RSSI→distance table, m.")
    table_step_m: float = Field(ge=SHORT_M, le=NEAR_M, description="Distance step of the RSSI→distance table, m.")

    @model_validator(mode="after")
    def _check_ranges(self) -> LFConfig:
        if self.table_max_m <= self.table_min_m:
            raise ValueError("lf.table_max_m must be greater than lf.table_min_m")
        if self.table_step_m > self.table_max_m - self.table_min_m:
            raise ValueError(f"lf.table_step_m ({self.table_step_m:g}) must not exceed the table's span, "
                             "lf.table_max_m - lf.table_min_m")
        hearing = self.hearing_range_m
        if hearing < self.reliable_range_m:
            raise ValueError(f"lf.sensitivity_db ({self.sensitivity_db:g} dB) with lf.rssi_at_1m_db ({self.rssi_at_1m_db:g} dB) hears "
                             f"only to {hearing:.2f} m; it must reach lf.reliable_range_m ({self.reliable_range_m} m): lower the first or raise the second")
        if self.table_max_m < hearing:
            raise ValueError(f"lf.table_max_m ({self.table_max_m} m) must cover the hearing range ({hearing:.2f} m on axis) of "
                             "lf.rssi_at_1m_db and lf.sensitivity_db: raise lf.table_max_m or lf.sensitivity_db")
        return self

    @property
    def hearing_range_m(self) -> float:
        """Distance at which the on-axis carrier falls to the receiver's sensitivity, m."""
        return float(10.0 ** ((self.rssi_at_1m_db - self.sensitivity_db) / self.falloff_db_per_decade))


Cadence = Annotated[float, Field(ge=-10.0, le=10.0)]  # a step-frequency coefficient: a person steps at most 5 times a second


class BeltConfig(Section):
    """Smart-belt IMU and recognition parameters (seed 002 §3.4). Values live in ``default.yaml``."""

    # --- accelerometer (z, vertical) ---
    accel_rate_hz: float = Field(ge=1.0, le=RATE_HZ, description="accelerometer sample rate, Hz")
    accel_noise_mps2: float = Field(ge=0, le=ACCEL_MPS2, description="σ of the white noise on each z sample, m/s²")
    walk_cadence_hz: tuple[Cadence, Cadence] = Field(description="walking step frequency = c0 + c1·speed: (c0 Hz, c1 Hz per m/s)")
    run_cadence_hz: tuple[Cadence, Cadence] = Field(description="running step frequency = c0 + c1·speed: (c0 Hz, c1 Hz per m/s)")
    walk_bounce_m: float = Field(ge=0, le=1.0, description="amplitude of the waist's vertical excursion when walking, m")
    run_bounce_m: float = Field(ge=0, le=1.0, description="amplitude of the waist's vertical excursion when running, m")
    gait_phase_jitter: float = Field(ge=0, le=GAIN, description="step-to-step irregularity: phase random walk, rad/√s")
    rest_sway_hz: float = Field(gt=0, le=100.0, description="mean frequency of the resting sway, Hz")
    rest_sway_mps2: float = Field(ge=0, le=ACCEL_MPS2, description="amplitude of the resting sway's vertical acceleration, m/s²")
    rest_phase_jitter: float = Field(ge=0, le=GAIN, description="irregularity of the resting sway: phase random walk, rad/√s")
    # --- movement recognition (Table 2) ---
    window_s: float = Field(gt=0, le=60.0, description="valid time period of the periodicity and the SMA, s")
    sign_deadband_mps2: float = Field(
        ge=0, le=ACCEL_MPS2, description="a sample's sign counts only beyond ±this (mean-removed), m/s²; within it the last sign holds"
    )
    min_sign_changes: int = Field(ge=1, le=COUNT, description="periodic if the window holds at least this many sign changes")
    sma_level2_mps2: float = Field(gt=0, le=ACCEL_MPS2, description="SMA at or above this is level 2, m/s²")
    sma_level3_mps2: float = Field(gt=0, le=ACCEL_MPS2, description="SMA at or above this is level 3, m/s²")
    # --- gyro (z, yaw rate) and rotation recognition ---
    gyro_period_s: float = Field(ge=TICK_S, le=10.0, description="gyro sample period, s")
    gyro_noise_dps: float = Field(ge=0, le=SPIN_DPS, description="σ of the white noise on each gyro sample, °/s")
    gyro_bias_dps: float = Field(ge=0, le=SPIN_DPS, description="σ of the constant bias drawn per belt, °/s")
    gait_yaw_wobble_deg: float = Field(ge=0, le=90, description="amplitude of the pelvis' yaw oscillation at the stride frequency, °")
    ma_samples: int = Field(ge=1, le=COUNT, description="length of the moving-average filter, gyro samples")
    rotation_on_dps: float = Field(gt=0, le=SPIN_DPS, description="rotation starts when |filtered rate| exceeds this, °/s")
    rotation_off_dps: float = Field(gt=0, le=SPIN_DPS, description="rotation ends when |filtered rate| falls below this, °/s")

    @model_validator(mode="after")
    def _check(self) -> BeltConfig:
        if self.sma_level3_mps2 <= self.sma_level2_mps2:
            raise ValueError("belt.sma_level3_mps2 must be greater than belt.sma_level2_mps2")
        if self.rotation_off_dps > self.rotation_on_dps:
            raise ValueError("belt.rotation_off_dps must not exceed belt.rotation_on_dps")
        if round(self.window_s * self.accel_rate_hz) < 2:
            raise ValueError("belt.window_s must hold at least 2 accelerometer samples")
        return self

    @property
    def window_samples(self) -> int:
        """Accelerometer samples in one recognition window."""
        return round(self.window_s * self.accel_rate_hz)

    def cadence_hz(self, posture: str, speed_mps: float) -> float:
        """Step frequency of the gait (walk or run) at a speed, Hz."""
        c0, c1 = self.run_cadence_hz if posture == "run" else self.walk_cadence_hz
        return max(0.0, c0 + c1 * max(0.0, speed_mps))


class WatchConfig(Section):
    """Smart-watch gesture and remote-control parameters (seed 002 §3.1, Table 1). Values in ``default.yaml``."""

    accel_rate_hz: float = Field(ge=1.0, le=RATE_HZ, description="wrist accelerometer sample rate, Hz")
    gesture_duration_s: float = Field(ge=TICK_S, le=60.0, description="duration of one hand stroke, s")
    recognition_delay_s: float = Field(ge=TICK_S, le=60.0, description="from the start of a gesture to its recognised command, s")
    gesture_peak_mps2: float = Field(gt=0, le=ACCEL_MPS2, description="peak hand acceleration of a stroke, m/s²")
    noise_mps2: float = Field(ge=0, le=ACCEL_MPS2, description="σ of the accelerometer noise per sample and axis, m/s²")
    cross_axis_leak: float = Field(ge=0, le=REL, description="σ of the stroke's off-axis components, fraction of the peak")
    circle_energy_ratio: float = Field(gt=0, le=1, description="second/first axis energy at or above this is a Circle")
    combination_window_s: float = Field(ge=0, le=60.0, description="two move gestures recognised within this give a diagonal, s")
    remote_speed_mps: float = Field(gt=0, le=FAST_MPS, description="speed of a remote-control move (diagonals too), m/s")
    remote_turn_rate_dps: float = Field(gt=0, le=SPIN_DPS, description="maximum rate of a remote-control rotation, °/s")
    move_duration_s: float = Field(ge=TICK_S, le=LONG_S, description="a move gesture drives for this long, s")
    rotate_angle_deg: float = Field(gt=0, le=3600, description="rotation of one Up / Down gesture, °")
    rotate_gain: float = Field(gt=0, le=GAIN, description="proportional gain of the rotation on the AHRS yaw error, 1/s")
    rotate_tolerance_deg: float = Field(gt=0, le=180, description="a rotation is done within this of its target, °")

    @model_validator(mode="after")
    def _check(self) -> WatchConfig:
        if self.recognition_delay_s < self.gesture_duration_s:
            raise ValueError(
                "watch.recognition_delay_s must be at least watch.gesture_duration_s (a gesture is recognised after it ends)"
            )
        if round(self.gesture_duration_s * self.accel_rate_hz) < 4:
            raise ValueError("watch.gesture_duration_s must hold at least 4 accelerometer samples")
        return self
