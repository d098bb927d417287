"""Oracles: the second form of each model the environment runs, kept here to check the shipped one.

The library keeps one implementation per idea, the one the environment runs (mostly plain Python
on the few values of one step, where numpy's fixed cost per call outweighs its arithmetic). The
forms below are the same models written the other way — numpy on whole arrays, or the general
routine the fast path specialises — as they stood in the library before; the tests of each model
(``tests/unit/``, ``tests/env/test_observation.py``) hold the shipped paths to them, bit for bit where the two forms do the same
operations, and to the last bit of a transcendental where numpy's SIMD routines and the C
library's may round differently (said at each test).

Nothing here is imported by the package.
"""

from __future__ import annotations

import math

import numpy as np

from petswarm_env.config import BeltConfig, IRConfig, LFConfig, RewardConfig
from petswarm_env.observe import AGE_SCALE_S, POS_SCALE_M, ObservationLayout, Readings
from petswarm_env.scenarios import ACTIVITIES
from petswarm_env.sim.geometry import ray_segment_distances
from petswarm_env.wearables.lf import LFFix

# -- IR module (petswarm_env/comms/ir.py): seed 000 §3.3 ---------------------------------------
_IR_MIN_DISTANCE_M = 0.01


def ir_wrap_angle(angle_rad: np.ndarray) -> np.ndarray:
    """Angles (rad) wrapped to the interval (−π, π] (the IR estimator's convention)."""
    wrapped = np.pi - np.mod(np.pi - np.asarray(angle_rad, dtype=float), 2.0 * np.pi)
    # Rounding can land an angle just above −π exactly on −π; that end of the interval is open.
    return np.where(wrapped <= -np.pi, wrapped + 2.0 * np.pi, wrapped)


def _ir_ring(num_receivers: int) -> tuple[np.ndarray, float, float, float]:
    delta = 2.0 * np.pi / num_receivers
    return np.arange(num_receivers) * delta, delta, float(np.cos(delta)), float(np.sin(delta))


def ir_received_strengths(cfg: IRConfig, distance_m, bearing_rad, occluded, rng: np.random.Generator) -> np.ndarray:
    """:func:`petswarm_env.comms.ir.received_strengths` on arrays: (M,) in, (M, K) out."""
    d = np.maximum(np.asarray(distance_m, dtype=float).reshape(-1), _IR_MIN_DISTANCE_M)
    bearing = np.asarray(bearing_rad, dtype=float).reshape(-1)
    occ = np.asarray(occluded, dtype=bool).reshape(-1)
    axes = _ir_ring(cfg.num_receivers)[0]
    lobe = np.maximum(0.0, np.cos(bearing[:, None] - axes)) ** cfg.lobe_exponent
    on_axis = cfg.strength_at_1m / d**2  # inverse-square fall-off
    on_axis = np.where(occ, on_axis * cfg.occlusion_attenuation, on_axis)
    on_axis = np.where(d > cfg.max_range_m, 0.0, on_axis)
    signal = on_axis[:, None] * lobe
    # the multiplicative, then the additive noise of every receiver: one draw of both
    z = rng.standard_normal((2, *signal.shape))
    noisy = signal * (1.0 + cfg.noise_rel * z[0])
    noisy = noisy + cfg.noise_abs * z[1]
    return np.minimum(np.maximum(noisy, 0.0), cfg.saturation)  # np.clip(noisy, 0, saturation)


def ir_estimate(cfg: IRConfig, strengths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`petswarm_env.comms.ir.estimate` on arrays: (M, K) in, three (M,) out."""
    s = np.asarray(strengths, dtype=float).reshape(-1, cfg.num_receivers)
    k = cfg.num_receivers
    _, delta, cos_d, sin_d = _ir_ring(k)
    rows = np.arange(s.shape[0])
    i = np.argmax(s, axis=1)
    s0 = s[rows, i]
    s_plus = s[rows, (i + 1) % k]
    s_minus = s[rows, (i - 1) % k]
    a = (s0 + (s_plus + s_minus) * cos_d) / (1.0 + 2.0 * cos_d**2)
    b = (s_plus - s_minus) * sin_d / (2.0 * sin_d**2)
    r = np.hypot(a, b)
    valid = (s0 >= cfg.detect_threshold) & (r > 0.0)
    safe_r = np.where(valid, r, 1.0)
    distance = np.where(valid, np.sqrt(cfg.strength_at_1m / safe_r), np.nan)
    bearing = np.where(valid, ir_wrap_angle(np.arctan2(b, a) + i * delta), np.nan)
    return distance, bearing, valid


# -- LF localisation (petswarm_env/wearables/lf.py): seed 002 §3.3, Eqs. 1–3 ------------------------
_LF_MIN_DISTANCE_M = 0.01


def lf_antenna_positions(cfg: LFConfig) -> np.ndarray:
    half = 0.5 * cfg.antenna_spacing_m
    return np.array([[cfg.antenna_forward_m, half], [cfg.antenna_forward_m, -half]])


def lf_calibration_curve(cfg: LFConfig, distance_m) -> np.ndarray:
    d = np.maximum(np.asarray(distance_m, dtype=float), _LF_MIN_DISTANCE_M)
    return cfg.rssi_at_1m_db - cfg.falloff_db_per_decade * np.log10(d)


def lf_rssi(cfg: LFConfig, rel_pos_body, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`petswarm_env.wearables.lf.lf_rssi` for N belt positions (N, 2): (N,) each."""
    p = np.asarray(rel_pos_body, dtype=float).reshape(-1, 2)
    n = p.shape[0]
    ant = lf_antenna_positions(cfg)
    d = np.hypot(p[:, None, 0] - ant[None, :, 0], p[:, None, 1] - ant[None, :, 1])  # (N, 2)
    bearing_deg = np.rad2deg(np.arctan2(p[:, 1], p[:, 0] - cfg.antenna_forward_m))
    excess_deg = np.maximum(0.0, np.abs(bearing_deg) - cfg.reliable_half_angle_deg)
    far = np.where(bearing_deg > 0.0, 1, 0)  # user on the left → the right antenna is the far one
    shadow = np.zeros((n, 2))
    shadow[np.arange(n), far] = cfg.distortion_loss_db_per_deg * excess_deg
    carrier = lf_calibration_curve(cfg, d) - shadow
    received = np.all(carrier >= cfg.sensitivity_db, axis=1)
    z = rng.standard_normal((n, 5))  # one draw: [common, own left, own right, scatter left, scatter right]
    common = cfg.noise_common_db * z[:, :1]
    own = cfg.noise_antenna_db * z[:, 1:3]
    scatter = (cfg.distortion_noise_db_per_deg * excess_deg)[:, None] * z[:, 3:5]
    rssi = carrier + common + own + scatter
    if cfg.rssi_step_db > 0.0:
        rssi = np.round(rssi / cfg.rssi_step_db) * cfg.rssi_step_db
    rssi = np.where(received[:, None], rssi, np.nan)
    return rssi[:, 0], rssi[:, 1], received


def lf_rssi_table(cfg: LFConfig) -> tuple[np.ndarray, np.ndarray]:
    count = int(np.floor((cfg.table_max_m - cfg.table_min_m) / cfg.table_step_m + 1e-9)) + 1
    dist = cfg.table_min_m + cfg.table_step_m * np.arange(count)
    rssi = cfg.rssi_at_1m_db - cfg.falloff_db_per_decade * np.log10(dist)
    return rssi[::-1].copy(), dist[::-1].copy()


def lf_rssi_to_distance(cfg: LFConfig, rssi_db) -> np.ndarray:
    rssi_inc, dist_inc = lf_rssi_table(cfg)
    return np.interp(rssi_db, rssi_inc, dist_inc)


def lf_triangle_formed(dl, dr, dw: float) -> np.ndarray:
    longest = np.maximum(np.maximum(dl, dr), dw)
    return (dl + dr + dw) - longest > longest


def lf_position_from_distances(cfg: LFConfig, dl, dr, heard=True) -> LFFix:
    """:func:`petswarm_env.wearables.lf.position_from_distances` on arrays."""
    dl = np.asarray(dl, dtype=float)
    dr = np.asarray(dr, dtype=float)
    dw = cfg.antenna_spacing_m
    valid = np.asarray(heard, dtype=bool) & lf_triangle_formed(dl, dr, dw)  # seed 002, Eq. 1
    safe_dl = np.where(valid, dl, 1.0)
    alpha = np.arccos(np.clip((safe_dl**2 + dw**2 - dr**2) / (2.0 * safe_dl * dw), -1.0, 1.0))  # Eq. 2
    x_p = safe_dl * np.cos(alpha) - dw / 2.0
    y_p = safe_dl * np.sin(alpha)
    d = np.sqrt(x_p**2 + y_p**2)  # Eq. 3
    theta_p = np.arctan(x_p / np.where(valid, y_p, 1.0))
    x_fwd, y_left, direction = y_p + cfg.antenna_forward_m, -x_p, -theta_p  # paper frame → body frame
    reliable = valid & (d <= cfg.reliable_range_m) & (np.abs(direction) <= np.deg2rad(cfg.reliable_half_angle_deg))
    nan = np.nan
    return LFFix(np.where(valid, x_fwd, nan), np.where(valid, y_left, nan), np.where(valid, d, nan),
                 np.where(valid, direction, nan), valid, reliable)


def lf_estimate(cfg: LFConfig, rssi_left, rssi_right) -> LFFix:
    rl = np.asarray(rssi_left, dtype=float)
    rr = np.asarray(rssi_right, dtype=float)
    heard = np.isfinite(rl) & np.isfinite(rr)
    dl = lf_rssi_to_distance(cfg, np.where(heard, rl, cfg.rssi_at_1m_db))
    dr = lf_rssi_to_distance(cfg, np.where(heard, rr, cfg.rssi_at_1m_db))
    return lf_position_from_distances(cfg, dl, dr, heard)


def lf_locate(cfg: LFConfig, rel_pos_body, rng: np.random.Generator) -> LFFix:
    """:func:`petswarm_env.wearables.lf.locate` for N belt positions (N, 2): a fix of arrays."""
    rssi_l, rssi_r, _ = lf_rssi(cfg, rel_pos_body, rng)
    return lf_estimate(cfg, rssi_l, rssi_r)


# -- geometry (petswarm_env/sim/geometry.py, comms/ir_channel.py) ----------------------------------
def _as_points(a) -> np.ndarray:
    return np.asarray(a, dtype=float).reshape(-1, 2)


def ray_circle_distances(origins, dirs, centers, radii, max_range: float) -> np.ndarray:
    """The ray cast that :func:`petswarm_env.sim.geometry.ring_first_hits` does for circles, per
    circle: (R, C) distances along R rays (origins, unit dirs) to C circles, ``inf`` where the ray
    misses, the circle is behind, the hit is beyond ``max_range`` or the origin is inside (or on)
    the circle."""
    o = _as_points(origins)
    d = _as_points(dirs)
    c = _as_points(centers)
    r = np.asarray(radii, dtype=float).reshape(-1)
    m = o[:, None, :] - c[None, :, :]  # (R, C, 2) centre -> origin
    b = np.einsum("rk,rck->rc", d, m)  # d·m
    cc = np.einsum("rck,rck->rc", m, m) - r[None, :] ** 2  # |m|² − r², ≤ 0 when inside
    disc = b * b - cc
    with np.errstate(invalid="ignore"):
        t = -b - np.sqrt(disc)  # nearer root of t² + 2bt + cc = 0
    hit = (cc > 0.0) & (disc >= 0.0) & (t >= 0.0) & (t <= max_range)
    return np.where(hit, t, np.inf)


def segments_blocked(
    p_from: np.ndarray,
    p_to: np.ndarray,
    centers: np.ndarray,
    radii: np.ndarray,
    exclude: np.ndarray,
) -> np.ndarray:
    """Line-of-sight test: does any non-excluded circle cut the segment ``p_from → p_to``?

    A circle blocks the segment when its centre is strictly closer than its radius to some point
    of the segment (a segment that only grazes the circle is not blocked).

    Args:
        p_from: (M, 2) segment start points, m.
        p_to: (M, 2) segment end points, m.
        centers: (C, 2) circle centres, m.
        radii: (C,) circle radii, m.
        exclude: (M, C) bool, True where circle c must be ignored for segment m (typically the
            bodies of the two robots the segment joins).

    Returns:
        (M,) bool, True where the line of sight is blocked.
    """
    p = _as_points(p_from)
    q = _as_points(p_to)
    c = _as_points(centers)
    r = np.asarray(radii, dtype=float).reshape(-1)
    excl = np.asarray(exclude, dtype=bool).reshape(p.shape[0], c.shape[0])
    v = q - p  # (M, 2)
    vv = np.einsum("mk,mk->m", v, v)
    pc = c[None, :, :] - p[:, None, :]  # (M, C, 2)
    # Parameter of the closest point on the segment, clipped to [0, 1]; degenerate segments use 0.
    u = np.einsum("mck,mk->mc", pc, v) / np.where(vv > 0.0, vv, 1.0)[:, None]
    u = np.clip(u, 0.0, 1.0)
    closest = p[:, None, :] + u[..., None] * v[:, None, :]
    dist2 = np.sum((c[None, :, :] - closest) ** 2, axis=-1)
    return np.any((dist2 < r[None, :] ** 2) & ~excl, axis=1)


def ring_first_hits_masked(origins, headings, angles, centers, radii, seg_a, seg_b, max_range):
    """:func:`petswarm_env.sim.geometry.ring_first_hits` as it was written before its calls were cut
    down: (origin, ray, circle) arrays, boolean hit masks, the range cut on every pair, every segment."""
    o, c = origins, centers
    ang = headings[:, None] + angles[None, :]
    dx, dy = np.cos(ang), np.sin(ang)
    mx, my = o[:, 0:1] - c[:, 0], o[:, 1:2] - c[:, 1]
    cc = mx * mx + my * my - radii**2
    cc = np.where(cc > 0.0, cc, np.inf)[:, None, :]
    b = dx[:, :, None] * mx[:, None, :] + dy[:, :, None] * my[:, None, :]
    disc = b * b - cc
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    hit = (disc >= 0.0) & (t >= 0.0) & (t <= max_range)
    d = np.where(hit, t, np.inf).min(axis=2) if len(c) else np.full(ang.shape, np.inf)
    if len(seg_a):
        dirs = np.stack([dx, dy], axis=-1).reshape(-1, 2)
        seg = ray_segment_distances(np.repeat(o, len(angles), axis=0), dirs, seg_a, seg_b, max_range)
        d = np.minimum(d, seg.min(axis=1).reshape(ang.shape))
    return d


# -- control arbiter (petswarm_env/control/arbiter.py) -----------------------------------------------
def safety_filter(stage, command, ranges):
    """``SafetyStage.filter`` (petswarm_env/control/arbiter.py) in numpy, as it was written before the
    plain-Python version."""
    v = np.array(command[:2], dtype=float)
    allowed = np.sqrt(stage.two_a * np.maximum(ranges - stage.stop, 0.0))
    over = (stage.dirs @ v > allowed + 1e-9) | (ranges < 0.5 * stage.stop)
    if not over.any():
        return None
    for k in np.flatnonzero(over):
        d = stage.dirs[k]
        excess = float(v @ d) - allowed[k]
        if excess > 0.0:
            v = v - excess * d
        if ranges[k] < 0.5 * stage.stop:
            v = v - stage.backoff * (1.0 - ranges[k] / (0.5 * stage.stop)) * d
    return float(v[0]), float(v[1]), float(command[2])


# -- smart belt (petswarm_env/wearables/belt.py): seed 002 §3.4 -------------------------------------
def belt_accel_samples(cfg: BeltConfig, phase: float, n: int, speed_mps: float, posture: str,
                       rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """The belt's n vertical-acceleration samples as the array model G + amp·sin(φ0 + cumsum(dφ))
    + σ·z (one draw of 2n normals: sensor noise, then phase jitter), and the phase after them."""
    dt = 1.0 / cfg.accel_rate_hz
    if posture in ("walk", "run"):
        f = cfg.cadence_hz(posture, speed_mps)
        amp = (2 * np.pi * f) ** 2 * (cfg.run_bounce_m if posture == "run" else cfg.walk_bounce_m)
        jitter = cfg.gait_phase_jitter
    elif posture == "rest":
        f, amp, jitter = cfg.rest_sway_hz, cfg.rest_sway_mps2, cfg.rest_phase_jitter
    else:
        f, amp, jitter = 0.0, 0.0, 0.0
    z = rng.standard_normal(2 * n)
    dphi = np.full(n, 2.0 * np.pi * f * dt)
    if jitter > 0.0 and amp > 0.0:
        dphi += jitter * np.sqrt(dt) * z[n:]
    phases = phase + np.cumsum(dphi)
    return 9.80665 + amp * np.sin(phases) + cfg.accel_noise_mps2 * z[:n], float(phases[-1] % (2 * np.pi))


def belt_window_stats(windows: np.ndarray, deadband: float) -> tuple[list[int], list[float]]:
    """The belt's first form of its window statistics (petswarm_env/wearables/belt_window.py): numpy
    on the windows (..., W) — the mean removed, the signs of each row as a byte string (the zeros
    dropped keep the last sign across the dead band), the SMA the mean magnitude. Flat lists."""
    w = windows.shape[-1]
    x = windows - np.add.reduce(windows, axis=-1, keepdims=True) * (1.0 / w)
    signs = ((x > deadband).view(np.int8) - (x < -deadband).view(np.int8)).tobytes()
    changes = []
    for i in range(0, len(signs), w):
        held = signs[i : i + w].replace(b"\x00", b"")
        changes.append(held.count(b"\x01\xff") + held.count(b"\xff\x01"))
    return changes, (np.add.reduce(np.abs(x), axis=-1) * (1.0 / w)).reshape(-1).tolist()


def sign_changes_loop(row: np.ndarray, deadband: float) -> int:
    """Sign changes of the mean-removed row, the sign held inside the dead band, as a plain loop
    (the belt counts them on byte strings)."""
    x = row - row.mean()
    last, count = 0, 0
    for v in x:
        s = 1 if v > deadband else (-1 if v < -deadband else 0)
        if s:
            count += last != 0 and s != last
            last = s
    return count


# -- reward (petswarm_env/reward.py) -----------------------------------------------------------------
def slave_reward(cfg: RewardConfig, formation_error_m: float, heading_error_rad: float, new_contacts: int,
                 action: np.ndarray, last_action: np.ndarray) -> float:
    """:func:`petswarm_env.reward.slave_rewards` for one slave, with numpy's ``@`` for ‖Δa‖²."""
    da = action - last_action
    return float(
        -cfg.formation * formation_error_m
        - cfg.heading * (1.0 - math.cos(heading_error_rad))
        - cfg.collision * new_contacts
        - cfg.smoothness * float(da @ da)
    )


# -- observation builder (petswarm_env/observe.py) ---------------------------------------------------
def carried_fix(m, yaw_rad: float, x_m: float, y_m: float) -> tuple[float, float]:
    """IR fix ``m`` (``knowledge.IRMeasurement``: where the other robot stood when measured) in this
    robot's body frame now, at its AHRS reading ``yaw_rad`` and dead-reckoned position ``(x_m, y_m)``:
    carried over this robot's own rotation and translation since (the oracle of ``observe._put_fix``)."""
    a = m.own_yaw_rad + m.bearing_rad  # the bearing in the odometry frame
    px = m.own_x_m + m.distance_m * math.cos(a) - x_m
    py = m.own_y_m + m.distance_m * math.sin(a) - y_m
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return c * px + s * py, c * py - s * px


def build_observation(layout: ObservationLayout, r: Readings) -> list[float]:
    """:func:`petswarm_env.observe.build_observation` as it was before its lookups were resolved
    once (offsets by name, ``min`` for the age clip, numpy for the ultrasonic scaling); the values
    as a list of Python floats (float64)."""

    def clip_age(age, scale):
        return min(age / scale, 1.0)

    def fix_xy(m):  # carried over own rotation and motion in the swarm, within the estimator's reach
        x, y = carried_fix(m, yaw_rad, *know.odometry_xy)
        f = layout.ir_max_m / math.sqrt(x * x + y * y) if x * x + y * y > layout.ir_max_m * layout.ir_max_m else 1.0
        return x * f / POS_SCALE_M, y * f / POS_SCALE_M

    now, odometry, yaw_rad, last_action, ultrasonic_m = r.now_s, r.odometry, r.yaw_rad, r.last_action, r.ultrasonic_m
    hierarchy_level, offset_from_master, us_max_range_m = r.hierarchy_level, r.offset_from_master_m, layout.us_max_range_m
    v = [0.0] * layout.size
    o = {name: sl.start for name, sl in layout.slices.items()}
    vmax, _, wmax = layout.limits
    know = r.know
    for base, link in zip([o[f"link{k}.present"] for k in range(len(layout._link_starts))], r.links):
        v[base] = 1.0
        nb = know.members.get(link.neighbour)
        m = know.ir.get(nb)
        if m is not None:
            v[base + 1] = 1.0
            v[base + 2], v[base + 3] = fix_xy(m)
            v[base + 4] = clip_age(now - m.time_s, AGE_SCALE_S)
        else:
            v[base + 4] = 1.0
        v[base + 5] = link.offset_m[0] / POS_SCALE_M
        v[base + 6] = link.offset_m[1] / POS_SCALE_M
        h = know.heading.get(nb)
        if h is not None:
            rel = h.relative_rad - (yaw_rad - h.own_yaw_rad)
            v[base + 7] = math.sin(rel)
            v[base + 8] = math.cos(rel)
            v[base + 9] = 1.0
            v[base + 10] = clip_age(now - h.time_s, AGE_SCALE_S)
        else:
            v[base + 8] = 1.0
            v[base + 10] = 1.0
    st = know.status
    i = o["master.valid"]
    v[o["master.leading"]] = 1.0 if know.mode == "leading" else 0.0  # from the joining / mode-change frames
    if st is not None:
        v[i] = 1.0
        v[i + 1] = clip_age(now - st.time_s, 1.0)
        v[i + 2] = st.velocity[0] / vmax
        v[i + 3] = st.velocity[1] / vmax
        v[i + 4] = st.velocity[2] / wmax
        v[o["master.activity"] + ACTIVITIES.index(st.activity)] = 1.0
        v[o["master.rotating"]] = 1.0 if st.user_rotating else 0.0
        v[o["master.turn_rate"]] = st.user_turn_rate_rps / wmax
        j = o["master.user_xy"]
        v[j] = st.user_position_m[0] / POS_SCALE_M
        v[j + 1] = st.user_position_m[1] / POS_SCALE_M
    else:
        v[i + 1] = 1.0
    m = know.ir.get(know.members.get(0))
    j = o["master.ir_valid"]
    if m is not None:
        v[j] = 1.0
        v[j + 1], v[j + 2] = fix_xy(m)
        v[j + 3] = clip_age(now - m.time_s, AGE_SCALE_S)
    else:
        v[j + 3] = 1.0
    j = o["anchor.ir_valid"]
    v[j + 3] = 1.0
    for member in sorted(know.members):  # the lowest other slave's member number with a fix in the age range
        m = know.ir.get(know.members[member])
        if member in (0, know.member) or member >= len(r.member_slots) or m is None or now - m.time_s >= AGE_SCALE_S:
            continue
        v[j] = 1.0
        v[j + 1], v[j + 2] = fix_xy(m)
        v[j + 3] = clip_age(now - m.time_s, AGE_SCALE_S)
        v[j + 4], v[j + 5] = r.member_slots[member][0] / POS_SCALE_M, r.member_slots[member][1] / POS_SCALE_M
        break
    j = o["self.odometry"]
    v[j], v[j + 1], v[j + 2] = odometry[0] / vmax, odometry[1] / vmax, odometry[2] / wmax
    j = o["self.yaw_sincos"]
    v[j], v[j + 1] = math.sin(yaw_rad), math.cos(yaw_rad)
    j = o["self.last_action"]
    v[j : j + 3] = last_action.tolist()
    j = o["self.offset_from_master_xy"]
    v[j], v[j + 1] = offset_from_master[0] / POS_SCALE_M, offset_from_master[1] / POS_SCALE_M
    j = o["self.ultrasonic"]
    v[j : j + len(ultrasonic_m)] = (ultrasonic_m / us_max_range_m).tolist()
    total = max(know.total_members, 1)
    v[o["self.hierarchy"]] = hierarchy_level / total
    v[o["self.members"]] = total / 16.0
    v[o["self.member"]] = know.member / 16.0
    n = len(ultrasonic_m)  # the ring's presence then location-known flags (a full ring: ones)
    flags = list(r.ultrasonic_flags) or [1.0] * (2 * n)
    j = o["self.ultrasonic_present"]
    v[j : j + n] = flags[:n]
    j = o["self.ultrasonic_location_known"]
    v[j : j + n] = flags[n:]
    return v
