"""Tests for the LF user localisation and wake-up of seed 002 (§3.2, §3.3, §4.2, Table 3)."""

import math

import numpy as np
import pytest

from petswarm.experiments.lf_accuracy import PAPER_RMSE, lf_accuracy_experiment
from petswarm_env.config import ConfigError, LFConfig, load_config
from petswarm_env.wearables.lf import (
    LFFix,
    antenna_positions,
    calibration_curve,
    estimate,
    lf_rssi,
    locate,
    position_from_distances,
    rssi_table,
    rssi_to_distance,
    triangle_formed,
    wakes_up,
)
from tests import oracles


def calibrated() -> LFConfig:
    """The calibrated LF parameters: the ``lf`` section of the default configuration."""
    return load_config().lf


def noiseless(cfg: LFConfig) -> LFConfig:
    return cfg.model_copy(update={"noise_common_db": 0.0, "noise_antenna_db": 0.0, "rssi_step_db": 0.0})


def true_distances(cfg: LFConfig, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ant = np.array(antenna_positions(cfg))
    p = np.asarray(pos, dtype=float).reshape(-1, 2)
    return np.hypot(*(p - ant[0]).T), np.hypot(*(p - ant[1]).T)


def fixes(fix_list: list[LFFix]) -> LFFix:
    """One fix of arrays from many fixes of floats."""
    return LFFix(*(np.array(field) for field in zip(*fix_list)))


def locate_many(cfg: LFConfig, pos, rng) -> LFFix:
    return fixes([locate(cfg, x, y, rng) for x, y in np.asarray(pos, dtype=float).tolist()])


def from_distances(cfg: LFConfig, dl, dr) -> LFFix:
    return fixes([position_from_distances(cfg, a, b) for a, b in zip(np.atleast_1d(dl).tolist(), np.atleast_1d(dr).tolist())])


# Straight ahead, left, right, close, far, and a nearly sideways one (both sides).
POSITIONS = np.array(
    [[1.0, 0.0], [0.25, 0.0], [1.2, 0.5], [0.8, -0.6], [0.3, 0.05], [1.9, -0.3], [0.2, 0.9], [0.1, -1.5]]
)


@pytest.mark.parametrize("forward", [0.0, 0.15])
def test_eqs_1_to_3_exact_on_noiseless_distances(forward):
    cfg = calibrated().model_copy(update={"antenna_forward_m": forward})
    pos = POSITIONS + [forward, 0.0]
    dl, dr = true_distances(cfg, pos)
    fix = from_distances(cfg, dl, dr)
    assert fix.valid.all()
    np.testing.assert_allclose(fix.x_fwd, pos[:, 0], atol=1e-9)
    np.testing.assert_allclose(fix.y_left, pos[:, 1], atol=1e-9)
    rel = pos - [forward, 0.0]  # the paper's d and θ are measured from the antenna midpoint
    np.testing.assert_allclose(fix.distance, np.hypot(rel[:, 0], rel[:, 1]), atol=1e-9)
    np.testing.assert_allclose(fix.direction, np.arctan2(rel[:, 1], rel[:, 0]), atol=1e-9)


def test_frame_left_antenna_is_on_the_left_and_directions_are_ccw():
    cfg = calibrated()
    ant = antenna_positions(cfg)
    assert ant[0][1] == pytest.approx(cfg.antenna_spacing_m / 2) and ant[1][1] == pytest.approx(-cfg.antenna_spacing_m / 2)
    # a user on the robot's left is closer to the left antenna, and is reported on the left
    dl, dr = true_distances(cfg, [[1.0, 0.4]])
    assert dl[0] < dr[0]
    fix = from_distances(cfg, dl, dr)
    assert fix.y_left[0] > 0 and fix.direction[0] > 0


def test_paper_formulas_by_hand():
    """Eq. 2–3 worked by hand for dl = 1.0 m, dr = 1.1 m, dw = 0.2 m."""
    cfg = calibrated()
    dl, dr, dw = 1.0, 1.1, cfg.antenna_spacing_m
    alpha = math.acos((dl**2 + dw**2 - dr**2) / (2 * dl * dw))
    x, y = dl * math.cos(alpha) - dw / 2, dl * math.sin(alpha)
    fix = position_from_distances(cfg, dl, dr)
    # the paper's x is to the right, ours (y_left) to the left; its θ = atan(x/y) is clockwise
    assert fix.y_left == pytest.approx(-x) and fix.x_fwd == pytest.approx(y)
    assert fix.distance == pytest.approx(math.hypot(x, y))
    assert fix.direction == pytest.approx(-math.atan(x / y))
    assert x < 0  # closer to the left antenna → left of the axis


def test_triangle_check_rejects_impossible_triples():
    dw = 0.2
    # |dl − dr| ≥ dw (one side longer than the other two together), dl + dr ≤ dw, and the exact
    # degenerate case (Eq. 1 is strict) give no triangle; a proper triangle passes.
    dl = np.array([1.0, 1.3, 0.05, 1.0, 1.0, 1.0])
    dr = np.array([1.3, 1.0, 0.05, 1.25, 1.0, 1.1])
    expect = np.array([False, False, False, False, True, True])
    np.testing.assert_array_equal([triangle_formed(a, b, dw) for a, b in zip(dl, dr)], expect)
    assert not triangle_formed(0.5, 0.7, 0.2)  # exactly degenerate: 0.5 + 0.2 = 0.7
    fix = from_distances(calibrated(), dl, dr)
    np.testing.assert_array_equal(fix.valid, expect)
    assert np.isnan(fix.distance[~expect]).all() and np.isnan(fix.direction[~expect]).all()
    assert np.isfinite(fix.distance[expect]).all()


def test_estimate_gives_no_fix_from_rssis_whose_distances_form_no_triangle():
    cfg = calibrated()
    rssi = [calibration_curve(cfg, 0.5), calibration_curve(cfg, 1.0)]  # 0.5 m and 1.0 m differ by more than dw
    fix = estimate(cfg, rssi[0], rssi[1])
    assert not fix.valid and np.isnan(fix.x_fwd)
    assert not estimate(cfg, math.nan, rssi[1]).valid


def test_table_is_the_noiseless_calibration_curve_built_once():
    cfg = calibrated()
    rssi, dist = rssi_table(cfg)
    assert rssi_table(cfg)[0] is rssi and isinstance(rssi, tuple)  # cached and immutable: no table is built per call
    assert np.all(np.diff(rssi) > 0)
    np.testing.assert_allclose(rssi, [calibration_curve(cfg, d) for d in dist])
    assert [rssi_to_distance(cfg, r) for r in rssi] == list(dist)  # exact at the rows
    d = np.linspace(0.3, 2.0, 50)
    looked_up = np.array([rssi_to_distance(cfg, calibration_curve(cfg, x)) for x in d.tolist()])
    np.testing.assert_allclose(looked_up, d, rtol=5e-3)
    # linear interpolation between the rows of a log curve, not the analytic inverse: it overshoots a little
    assert np.all(looked_up >= d - 1e-12) and np.max(looked_up - d) > 1e-4


def test_noiseless_chain_is_accurate_inside_the_reliable_region():
    cfg = noiseless(calibrated())
    ang = np.deg2rad(np.linspace(-25, 25, 11))
    dist = np.linspace(0.25, 2.0, 8)
    a, d = np.meshgrid(ang, dist)
    pos = np.stack([d.ravel() * np.cos(a.ravel()), d.ravel() * np.sin(a.ravel())], axis=1)
    fix = locate_many(cfg, pos, np.random.default_rng(0))
    assert fix.valid.all()
    core = (d.ravel() < 1.9) & (np.abs(a.ravel()) < np.deg2rad(20.0))
    assert fix.reliable[core].all()
    assert np.max(np.abs(fix.distance - d.ravel())) < 0.01  # table interpolation only
    assert np.max(np.abs(fix.direction - a.ravel())) < np.deg2rad(3.0)


def test_no_fix_beyond_2_m():
    cfg = calibrated()
    rng = np.random.default_rng(1)
    bearings = np.deg2rad([0.0, 10.0, -20.0, 25.0, 45.0, -90.0, 180.0])
    for dist in (2.1, 2.5, 3.0, 5.0):
        pos = np.stack([dist * np.cos(bearings), dist * np.sin(bearings)], axis=1)
        pos = np.repeat(pos, 20, axis=0)
        for x, y in pos.tolist():
            rl, rr, received = lf_rssi(cfg, x, y, rng)
            assert not received and math.isnan(rl) and math.isnan(rr), dist
        assert not locate_many(cfg, pos, rng).valid.any()
    # ...but everything inside 2 m and ±25° is received
    inside = np.deg2rad([-25.0, 0.0, 25.0])
    pos = np.stack([2.0 * np.cos(inside), 2.0 * np.sin(inside)], axis=1)
    assert all(lf_rssi(cfg, x, y, rng)[2] for x, y in np.repeat(pos, 20, axis=0).tolist())


def test_errors_outside_25_deg_clearly_larger_than_inside():
    cfg = calibrated()
    dists = np.array([0.5, 1.0, 1.5])
    inside = lf_accuracy_experiment(cfg, np.random.default_rng(0), 40, distances_m=dists, angles_deg=np.array([-20.0, 0.0, 20.0]))
    outside = lf_accuracy_experiment(cfg, np.random.default_rng(0), 40, distances_m=dists, angles_deg=np.array([-55.0, 55.0]))
    assert outside["rmse_direction_deg"]["sim"] > 2.0 * inside["rmse_direction_deg"]["sim"]
    assert outside["rmse_y_cm"]["sim"] > 2.0 * inside["rmse_y_cm"]["sim"]
    assert outside["valid_fraction"] < inside["valid_fraction"] == 1.0
    # and it is the modelled distortion, not only the geometry
    plain = cfg.model_copy(update={"distortion_loss_db_per_deg": 0.0, "distortion_noise_db_per_deg": 0.0})
    undistorted = lf_accuracy_experiment(plain, np.random.default_rng(0), 40, distances_m=dists, angles_deg=np.array([-55.0, 55.0]))
    assert outside["rmse_direction_deg"]["sim"] > 1.3 * undistorted["rmse_direction_deg"]["sim"]


def test_calibrated_accuracy_within_20_percent_of_table_3():
    res = lf_accuracy_experiment(calibrated(), np.random.default_rng(0), samples_per_point=20)
    assert res["valid_fraction"] == 1.0
    for key, paper in PAPER_RMSE.items():
        assert res[key]["paper"] == paper
        assert res[key]["sim"] == pytest.approx(paper, rel=0.20), key
    n = 8 * 3 * 20  # 8 distances × 3 directions × 20 samples
    assert res["actual_m"].shape == res["estimated_m"].shape == (n, 2)
    assert len(res["points"]) == 8 * 3


def test_same_seed_same_output():
    cfg = calibrated()
    pos = [(1.0, 0.2), (0.5, -0.1), (1.8, 0.3)]
    a, b, c = ([lf_rssi(cfg, x, y, rng) for x, y in pos] for rng in map(np.random.default_rng, (7, 7, 8)))
    assert a == b and a != c
    r1 = lf_accuracy_experiment(cfg, np.random.default_rng(3), 5)
    r2 = lf_accuracy_experiment(cfg, np.random.default_rng(3), 5)
    np.testing.assert_array_equal(r1["estimated_m"], r2["estimated_m"])
    assert r1["rmse_x_cm"] == r2["rmse_x_cm"]


def test_locate_one_user_per_burst_gives_scalars():
    cfg = calibrated()
    fix = locate(cfg, 1.0, 0.1, np.random.default_rng(0))
    assert isinstance(fix.x_fwd, float) and isinstance(fix.valid, bool) and isinstance(fix.reliable, bool)
    assert fix.valid and abs(fix.distance - math.hypot(1.0, 0.1)) < 0.3
    far = locate(cfg, 4.0, 0.0, np.random.default_rng(0))
    assert not far.valid and math.isnan(far.distance)


def one_point_positions(cfg: LFConfig, rng: np.random.Generator, n_per_group: int) -> np.ndarray:
    """Belt positions for the fast-path check: inside the reliable region, outside ±25°, behind the
    robot, beyond the hearing range, within centimetres of the antennas, plus the edge cases."""
    mid = np.array([cfg.antenna_forward_m, 0.0])

    def polar(d, a_deg):
        a = np.deg2rad(a_deg)
        return mid + np.stack([d * np.cos(a), d * np.sin(a)], axis=1)

    k = n_per_group
    groups = [
        polar(rng.uniform(0.0, 2.0, k), rng.uniform(-25.0, 25.0, k)),  # reliable region
        polar(rng.uniform(0.0, 2.3, k), rng.choice([-1.0, 1.0], k) * rng.uniform(25.0, 90.0, k)),  # outside ±25°
        polar(rng.uniform(0.0, 2.3, k), rng.uniform(90.0, 270.0, k)),  # behind the robot
        polar(rng.uniform(2.0, 10.0, k), rng.uniform(-180.0, 180.0, k)),  # beyond the hearing range
        np.array(antenna_positions(cfg))[rng.integers(0, 2, k)] + rng.normal(0.0, 0.02, (k, 2)),  # at the antennas
    ]
    ant = np.array(antenna_positions(cfg))
    edges = [ant[0], ant[1], mid, [0.0, 0.0], [-0.0, -0.0], mid + [1e-9, 0.0], mid + [-1.0, 0.0], [1e3, 0.0]]
    edges += list(polar(np.array([0.5, 1.0, 2.0, cfg.hearing_range_m] * 2), np.repeat([-25.0, 25.0], 4)))
    edges += list(polar(np.full(4, cfg.reliable_range_m), [0.0, 10.0, -10.0, 180.0]))
    return np.concatenate(groups + [np.repeat(np.asarray(edges, dtype=float), 20, axis=0)])


def assert_same_fix(fast: LFFix, vec: LFFix, i, where) -> None:
    for name, a, b in zip(LFFix._fields, fast, vec):
        b = b[i] if isinstance(b, np.ndarray) else b
        assert type(a) is type(b.item() if isinstance(b, np.generic) else b), (where, name)
        assert a == b or (math.isnan(a) and math.isnan(b)), (where, name, a, b)


@pytest.mark.parametrize(
    "update, n_per_group",
    [({}, 4800), ({"antenna_forward_m": 0.15, "rssi_step_db": 0.5}, 1000), ({"rssi_step_db": 0.0}, 1000)],
)
def test_locate_is_bit_identical_to_the_numpy_oracle(update, n_per_group):
    """locate() (plain Python, one position: the env's path) gives exactly the fix of the numpy
    chain (tests/oracles.py: lf_rssi → estimate → position_from_distances) on that point, and
    leaves the rng in the same state, for the same seed — on (1, 2) and as one (N, 2) call."""
    cfg = calibrated().model_copy(update=update)
    pos = one_point_positions(cfg, np.random.default_rng(11), n_per_group)
    assert len(pos) >= (20_000 if not update else 5_000)
    rng_fast, rng_vec = np.random.default_rng(2024), np.random.default_rng(2024)
    for i, p in enumerate(pos):
        fast = locate(cfg, float(p[0]), float(p[1]), rng_fast)
        vec = oracles.lf_locate(cfg, p[None, :], rng_vec)  # the numpy chain on (1, 2)
        assert_same_fix(fast, vec, 0, p)
        if i % 97 == 0:
            assert rng_fast.bit_generator.state == rng_vec.bit_generator.state
    assert rng_fast.bit_generator.state == rng_vec.bit_generator.state

    # ...and the same fixes as one (N, 2) call (numpy's elementwise results do not depend on N)
    many = oracles.lf_locate(cfg, pos, np.random.default_rng(2024))
    rng_fast = np.random.default_rng(2024)
    for i, p in enumerate(pos):
        assert_same_fix(locate(cfg, float(p[0]), float(p[1]), rng_fast), many, i, p)

    # the positions reach every branch: reliable, valid only, heard but no triangle (Eq. 1), not heard
    _, _, received = oracles.lf_rssi(cfg, pos, np.random.default_rng(2024))
    assert many.reliable.sum() > 500
    assert (many.valid & ~many.reliable).sum() > 500
    assert (received & ~many.valid).sum() > 500
    assert (~received).sum() > 500


def test_the_chain_stages_equal_the_numpy_oracle():
    """Each stage on its own: calibration curve, table, lookup, Eqs. 1–3 and the estimator."""
    cfg = calibrated()
    rng = np.random.default_rng(5)
    d = np.concatenate([rng.uniform(0.0, 3.0, 2000), [0.0, 0.005, 0.01, 1.0]])
    assert [calibration_curve(cfg, x) for x in d.tolist()] == oracles.lf_calibration_curve(cfg, d).tolist()
    assert rssi_table(cfg) == tuple(tuple(v.tolist()) for v in oracles.lf_rssi_table(cfg))
    dl, dr = rng.uniform(0.05, 2.5, 3000), rng.uniform(0.05, 2.5, 3000)
    dl[:1000] = dr[:1000] + rng.uniform(-0.19, 0.19, 1000)  # mostly triangles
    got, want = from_distances(cfg, dl, dr), oracles.lf_position_from_distances(cfg, dl, dr)
    for i in range(len(dl)):
        assert_same_fix(LFFix(*(f[i].item() for f in got)), want, i, (dl[i], dr[i]))
    assert got.valid.sum() > 1000 and (~got.valid).sum() > 1000
    rl, rr = oracles.lf_calibration_curve(cfg, dl) + 0.3, oracles.lf_calibration_curve(cfg, dr)
    rl[::7] = np.nan
    want = oracles.lf_estimate(cfg, rl, rr)
    for i in range(len(rl)):
        assert_same_fix(estimate(cfg, float(rl[i]), float(rr[i])), want, i, i)


def test_rssi_to_distance_is_np_interp():
    cfg = calibrated()
    xp, fp = (np.array(v) for v in rssi_table(cfg))
    xl = xp.tolist()
    vals = [v for x in xl for v in (x, math.nextafter(x, -math.inf), math.nextafter(x, math.inf))]
    vals += ((xp[:-1] + xp[1:]) / 2).tolist() + [float(k) for k in range(-10, 120)] + [k + 0.5 for k in range(-10, 120)]
    vals += np.random.default_rng(0).uniform(xl[0] - 5.0, xl[-1] + 5.0, 50_000).tolist() + [-1e300, 1e300, 0.0, -0.0]
    expect = np.interp(np.array(vals), xp, fp).tolist()
    assert [rssi_to_distance(cfg, v) for v in vals] == expect


@pytest.mark.parametrize(
    "distance, sent, stored, wakes",
    [
        (0.5, 0x5A3C, 0x5A3C, True),  # right pattern, inside 1 m
        (1.0, 0x5A3C, 0x5A3C, True),  # at the edge of the wake range
        (0.5, 0x5A3C, 0x1234, False),  # wrong pattern: ignored
        (1.5, 0x5A3C, 0x5A3C, False),  # right pattern, too far
        (1.5, 0x5A3C, 0x1234, False),
    ],
)
def test_wake_up_pattern(distance, sent, stored, wakes):
    assert wakes_up(calibrated(), distance, sent, stored) is wakes


def test_config_from_seed_002_and_checked():
    cfg = calibrated()
    assert cfg.antenna_spacing_m == 0.20 and cfg.burst_period_s == 0.35
    assert cfg.wake_period_s == 3.0 and cfg.wake_range_m == 1.0
    assert cfg.reliable_range_m == 2.0 and cfg.reliable_half_angle_deg == 25.0
    assert cfg.reliable_range_m <= cfg.hearing_range_m <= cfg.table_max_m
    with pytest.raises(ConfigError, match="sensitivity"):
        load_config(overrides={"lf.sensitivity_db": 45.0})  # would hear only to ≈ 1.9 m
    with pytest.raises(ConfigError, match="lf"):
        load_config(overrides={"lf.noise_common_db": -1.0})
