"""Tests for the IR relative-location module (seed 000 §3.3, §4.3)."""


import numpy as np
import pydantic
import pytest

from petswarm.experiments.ir_accuracy import (
    PAPER_ANGLES_DEG,
    PAPER_DIRECTION_RMSE_DEG,
    PAPER_DISTANCE_RMSE_CM,
    PAPER_DISTANCES_M,
    PAPER_SAMPLES_PER_POINT,
    accuracy_experiment,
)
from petswarm_env.config import IRConfig, load_config
from petswarm_env.comms import ir
from petswarm_env.sim.geometry import wrap_angle
import math
from petswarm_env.comms.ir_channel import IRChannel, line_of_sight_blocked
from petswarm_env.config import load_config
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.sim.world import World
from tests import oracles


def received_strengths(cfg, distance_m, bearing_rad, occluded, rng) -> np.ndarray:
    """The module's physics on array-likes: (M,) in, an (M, K) array out."""
    as_list = lambda v, t: np.asarray(v, dtype=t).reshape(-1).tolist()  # noqa: E731
    return np.array(ir.received_strengths(cfg, as_list(distance_m, float), as_list(bearing_rad, float),
                                          as_list(occluded, bool), rng))


def estimate(cfg, strengths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The module's estimator on an (M, K) array: three (M,) arrays."""
    return tuple(np.array(v) for v in ir.estimate(cfg, np.asarray(strengths, dtype=float).tolist()))


def calibrated_config() -> IRConfig:
    """The calibrated IR parameters: the ``ir`` section of the default configuration."""
    return load_config().ir


def ideal_config(num_receivers: int = 8) -> IRConfig:
    """Cosine lobe, no noise, no saturation: the estimator's own assumptions."""
    return IRConfig(
        num_receivers=num_receivers,
        strength_at_1m=600.0,
        lobe_exponent=1.0,
        noise_rel=0.0,
        noise_abs=0.0,
        saturation=1e12,
        detect_threshold=1e-6,
        occlusion_attenuation=0.05,
        max_range_m=100.0,
    )


def noise_free(cfg: IRConfig) -> IRConfig:
    return cfg.model_copy(update={"noise_rel": 0.0, "noise_abs": 0.0})


@pytest.mark.parametrize("num_receivers", [7, 8, 12])
def test_estimator_exact_for_ideal_cosine_lobe(num_receivers):
    cfg = ideal_config(num_receivers)
    delta = 2 * np.pi / num_receivers
    # A dense sweep plus bearings right around receiver 0 and receiver K−1 (wrap-around of the
    # neighbour indices) and the ±π seam.
    special = np.array(
        [
            0.0,
            1e-9,
            -1e-9,
            0.3 * delta,
            -0.3 * delta,
            -delta,
            -delta + 1e-7,
            -delta - 1e-7,
            -0.5 * delta,
            0.5 * delta,
            np.pi,
            -np.pi + 1e-9,
        ]
    )
    bearings = np.concatenate([np.linspace(-np.pi, np.pi, 1441), special])
    distances = np.resize([0.2, 0.4, 0.77, 1.0, 1.6, 2.5, 5.0], bearings.size)
    s = received_strengths(cfg, distances, bearings, np.zeros(bearings.size, bool), np.random.default_rng(0))
    d_est, b_est, valid = estimate(cfg, s)
    assert valid.all()
    np.testing.assert_allclose(d_est, distances, rtol=0, atol=1e-9)
    np.testing.assert_allclose(wrap_angle(b_est - bearings), 0.0, atol=1e-9)
    assert np.all((b_est > -np.pi) & (b_est <= np.pi))


def test_estimator_uses_strongest_receiver_offset():
    # Source exactly on receiver 5's axis: only the strongest receiver's offset gives the bearing.
    cfg = ideal_config(8)
    bearing = 5 * 2 * np.pi / 8
    s = received_strengths(cfg, [1.0], [bearing], [False], np.random.default_rng(0))
    assert np.argmax(s[0]) == 5
    _, b_est, _ = estimate(cfg, s)
    assert b_est[0] == pytest.approx(wrap_angle(bearing), abs=1e-12)


def test_strength_falls_with_distance_and_peaks_on_facing_receiver():
    cfg = noise_free(calibrated_config())
    k = cfg.num_receivers
    delta = 2 * np.pi / k
    distances = np.array([0.5, 1.0, 1.5, 2.0])
    for i in range(k):
        s = received_strengths(cfg, distances, np.full(4, i * delta), np.zeros(4, bool), np.random.default_rng(0))
        assert np.all(np.argmax(s, axis=1) == i)
        assert np.all(np.diff(s[:, i]) < 0)
        # Inverse square on the facing receiver (below saturation).
        np.testing.assert_allclose(s[:, i], cfg.strength_at_1m / distances**2)
    # With noise, the mean reading still falls with distance.
    noisy = calibrated_config()
    means = [
        received_strengths(noisy, np.full(500, d), np.zeros(500), np.zeros(500, bool), np.random.default_rng(1))[
            :, 0
        ].mean()
        for d in distances
    ]
    assert np.all(np.diff(means) < 0)


def test_saturation_clips_readings():
    cfg = calibrated_config()
    s = received_strengths(cfg, np.full(100, 0.05), np.zeros(100), np.zeros(100, bool), np.random.default_rng(0))
    assert s.max() == cfg.saturation
    assert s.min() >= 0.0


def test_occlusion_lowers_strength_and_can_invalidate():
    cfg = calibrated_config()
    n = 200
    d = np.full(n, 1.0)
    b = np.zeros(n)
    clear = received_strengths(cfg, d, b, np.zeros(n, bool), np.random.default_rng(3))
    blocked = received_strengths(cfg, d, b, np.ones(n, bool), np.random.default_rng(3))
    assert blocked[:, 0].mean() < 0.2 * clear[:, 0].mean()
    assert estimate(cfg, clear)[2].all()
    assert not estimate(cfg, blocked)[2].any()
    # Very close, the attenuated signal can still be detected.
    close = received_strengths(cfg, np.full(n, 0.4), b, np.ones(n, bool), np.random.default_rng(3))
    assert estimate(cfg, close)[2].mean() > 0.9


def test_below_threshold_is_invalid_nan():
    cfg = calibrated_config()
    s = np.full((3, cfg.num_receivers), 0.5 * cfg.detect_threshold)
    s[1, 2] = 2.0 * cfg.detect_threshold  # this row is detected
    d, b, valid = estimate(cfg, s)
    np.testing.assert_array_equal(valid, [False, True, False])
    assert np.isnan(d[[0, 2]]).all() and np.isnan(b[[0, 2]]).all()
    assert np.isfinite(d[1]) and np.isfinite(b[1])


def test_beyond_max_range_is_never_detected():
    cfg = calibrated_config()
    n = 1000
    s = received_strengths(
        cfg, np.full(n, cfg.max_range_m + 0.1), np.zeros(n), np.zeros(n, bool), np.random.default_rng(0)
    )
    assert not estimate(cfg, s)[2].any()


def test_calibrated_lobe_carries_model_error():
    cfg = noise_free(calibrated_config())
    assert cfg.lobe_exponent != 1.0
    delta = 2 * np.pi / cfg.num_receivers
    s = received_strengths(cfg, [1.0], [0.3 * delta], [False], np.random.default_rng(0))
    d, b, _ = estimate(cfg, s)
    assert abs(d[0] - 1.0) > 1e-3
    assert abs(b[0] - 0.3 * delta) > 1e-3


def test_calibrated_config_reproduces_table_4():
    res = accuracy_experiment(
        calibrated_config(), np.random.default_rng(0), PAPER_DISTANCES_M, PAPER_ANGLES_DEG, PAPER_SAMPLES_PER_POINT
    )
    assert len(res["points"]) == 9 * 7
    assert res["valid_fraction"] == 1.0
    assert res["distance_rmse_cm"] == pytest.approx(PAPER_DISTANCE_RMSE_CM, rel=0.15)
    assert res["direction_rmse_deg"] == pytest.approx(PAPER_DIRECTION_RMSE_DEG, rel=0.15)


def test_paper_grid():
    np.testing.assert_allclose(PAPER_DISTANCES_M, [0.4, 0.6, 0.8, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0])
    np.testing.assert_allclose(PAPER_ANGLES_DEG, [0, 30, 60, 90, 120, 150, 180])


def test_config_validation():
    fields = ideal_config().model_dump()
    with pytest.raises(pydantic.ValidationError):
        IRConfig(**{**fields, "num_receivers": 6})
    with pytest.raises(pydantic.ValidationError):
        IRConfig(**{**fields, "noise_rel": -0.1})
    with pytest.raises(pydantic.ValidationError):
        IRConfig(**{**fields, "occlusion_attenuation": 1.5})
    with pytest.raises(pydantic.ValidationError):
        IRConfig(**{**fields, "unknown": 1})
    missing = dict(fields)
    del missing["saturation"]
    with pytest.raises(pydantic.ValidationError):
        IRConfig(**missing)
    with pytest.raises(pydantic.ValidationError):
        ideal_config().num_receivers = 9


def test_ir_measure_of_a_slot_equals_the_per_receiver_model():
    """One IR slot measured for all receivers at once equals the optical model run on each
    receiver alone (occlusion, ring, estimator), given the same noise."""
    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    rng = np.random.default_rng(3)
    for p, th in zip(rng.uniform(-2.0, 2.0, (6, 2)), rng.uniform(-3.0, 3.0, 6)):
        world.add_robot(p, th)
    channel = IRChannel(world, cfg.ir, np.random.default_rng(7))
    tx, rxs = 2, [0, 1, 3, 4, 5]
    dist, bearing, valid = channel.measure(tx, rxs)
    centers, radii = world.body_circles()
    z = np.random.default_rng(7).standard_normal((2, len(rxs), cfg.ir.num_receivers))  # the slot's noise
    for j, r in enumerate(rxs):
        others = [i for i in range(len(centers)) if i not in (r, tx)]
        delta = centers[tx] - centers[r]
        occluded = oracles.segments_blocked(centers[r:r + 1], centers[tx:tx + 1], centers[others], radii[others],
                                             np.zeros((1, len(others)), bool))
        b = math.atan2(delta[1], delta[0]) - world.robots[r].heading
        d = max(math.hypot(*delta), 0.01)
        lobe = np.maximum(0.0, np.cos(b - np.arange(cfg.ir.num_receivers) * cfg.ir.spacing_rad)) ** cfg.ir.lobe_exponent
        on_axis = 0.0 if d > cfg.ir.max_range_m else cfg.ir.strength_at_1m / d**2 * (cfg.ir.occlusion_attenuation if occluded[0] else 1.0)
        s = np.clip(on_axis * lobe * (1 + cfg.ir.noise_rel * z[0, j]) + cfg.ir.noise_abs * z[1, j], 0.0, cfg.ir.saturation)
        d_one, b_one, ok_one = oracles.ir_estimate(cfg.ir, s[None, :])
        assert valid[j] == ok_one[0]
        if ok_one[0]:
            assert dist[j] == pytest.approx(d_one[0], abs=1e-9)
            assert bearing[j] == pytest.approx(b_one[0], abs=1e-9)
    assert any(valid)


@pytest.mark.parametrize("seed", range(5))
def test_ir_model_equals_the_numpy_oracle(seed):
    """ir.received_strengths / ir.estimate (plain Python, the env's path) give the numbers of their
    numpy forms (tests/oracles.py), also for saturated, occluded, out-of-range and undetected rows:
    validity and distance exactly; the readings and the bearing to the last bit of the lobe's pow and
    of atan2 (numpy's SIMD ``power`` and ``arctan2`` on AVX-512 CPUs and the C library's ``pow`` and
    ``atan2`` may round differently)."""
    cfg = load_config().ir
    rng = np.random.default_rng(seed)
    m = 9
    d = np.concatenate([[0.05, 0.3, cfg.max_range_m + 0.5, 5.0], rng.uniform(0.1, 3.5, m - 4)])
    b = rng.uniform(-4.0, 4.0, m)
    occ = rng.random(m) < 0.3
    want = oracles.ir_received_strengths(cfg, d, b, occ, np.random.default_rng(seed))
    got = ir.received_strengths(cfg, d.tolist(), b.tolist(), occ.tolist(), np.random.default_rng(seed))
    np.testing.assert_allclose(np.array(got), want, rtol=1e-13, atol=1e-12)
    assert np.array_equal(np.array(got) == 0.0, want == 0.0)  # the same clipped and unlit receivers
    assert (want == cfg.saturation).any() and (want.max(axis=1) < cfg.detect_threshold).any()
    d1, b1, ok1 = oracles.ir_estimate(cfg, np.array(got))
    d2, b2, ok2 = ir.estimate(cfg, got)
    assert np.array_equal(ok1, ok2) and ok1.any() and not ok1.all()
    assert np.array_equal(d1, np.array(d2), equal_nan=True)
    np.testing.assert_allclose(np.array(b2), b1, rtol=0, atol=1e-12)  # nan where invalid, in both
    assert np.array_equal(ir.estimate(cfg, [[1.0] * cfg.num_receivers])[2], [cfg.detect_threshold <= 1.0])


def _two_robots_measured(overrides: dict, a=(-0.9, 0.0), b=(0.9, 0.0), trials: int = 40) -> list[bool]:
    """Robot ``b`` transmits, robot ``a`` receives, ``trials`` slots in a world built from the
    default config with ``overrides``: the validity of each reading (the user stands far away)."""
    cfg = load_config(overrides=overrides)
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    world.users[0].body.position = (0.0, 30.0)  # out of the line of sight
    world.invalidate_truth()
    world.add_robot(a, 0.0)
    world.add_robot(b, math.pi)
    channel = IRChannel(world, cfg.ir, np.random.default_rng(5))
    return [channel.measure(1, [0])[2][0] for _ in range(trials)]


def test_a_box_between_two_robots_blocks_their_ir():
    """Seed 000 §3.3 (SPEC §3.2): the IR module needs a line of sight. Across a 1 m box the reading
    was a valid 2.70 m estimate before boxes blocked IR; now no reading is valid, while the same
    robots with the box moved aside read each other in every slot."""
    box = {"center_m": [0.0, 0.0], "size_m": [1.0, 1.0]}
    assert not any(_two_robots_measured({"world.obstacles": [box]}))
    aside = {"center_m": [0.0, 3.0], "size_m": [1.0, 1.0]}
    assert all(_two_robots_measured({"world.obstacles": [aside]}))


def test_a_wall_between_two_robots_blocks_their_ir_and_a_clear_line_stays_valid():
    """The arena wall at x = 1 between a robot inside and one outside blocks; the same pair with
    the wall beyond them (a larger arena), or both inside, reads in every slot."""
    assert not any(_two_robots_measured({"world.arena_m": [2.0, 8.0]}, a=(0.3, 0.0), b=(1.7, 0.0)))
    assert all(_two_robots_measured({"world.arena_m": [8.0, 8.0]}, a=(0.3, 0.0), b=(1.7, 0.0)))
    assert all(_two_robots_measured({"world.arena_m": [2.0, 8.0]}, a=(-0.7, 0.0), b=(0.7, 0.0)))


def test_a_box_beside_the_line_of_sight_does_not_block():
    """Only a segment that crosses the line blocks: a box whose bounding box overlaps the slot's but
    which lies beside the line (and one touched at a corner, the grazing case) leaves it clear."""
    beside = {"center_m": [0.0, 0.6], "size_m": [0.6, 0.6]}  # its lower edge at y = 0.3
    assert all(_two_robots_measured({"world.obstacles": [beside]}))
    corner = {"center_m": [0.25, 0.25], "size_m": [0.5, 0.5]}  # corner at (0, 0), on the line
    assert all(_two_robots_measured({"world.obstacles": [corner]}))


def test_measure_rows_is_the_readings_then_the_estimate_to_the_bit():
    """``ir.measure_rows`` (what the IR channel calls for a slot) gives exactly what
    ``received_strengths`` then ``estimate`` give from the same noise: near, far (invalid),
    occluded and behind-the-robot pairs, compared as hex strings (NaN included)."""
    cfg = calibrated_config()
    distance = [0.3, 1.2, 2.9, 9.0, 0.005, 1.5]
    bearing = [0.0, 1.1, -2.8, 0.4, 3.0, -1.2]
    occluded = [False, True, False, False, False, True]
    optics = ir.Optics(cfg)  # one for every slot, as the IR channel keeps it: its scratch grows with the slots
    for n in (2, 6, 18, 5):
        d, b, o = (distance * 3)[:n], (bearing * 3)[:n], (occluded * 3)[:n]
        want = ir.estimate(cfg, ir.received_strengths(cfg, d, b, o, np.random.default_rng(n)))
        z = np.random.default_rng(n).standard_normal((2, n, cfg.num_receivers))
        got = ir.measure_rows(optics, d, b, o, z)
        assert [type(v) for v in got[2]] == [bool] * n and True in got[2]
        assert [[float(v).hex() for v in col] for col in got] == [[float(v).hex() for v in col] for col in want]
    assert optics.k == cfg.num_receivers


def test_a_slots_noise_is_the_generators_next_normals_across_blocks():
    """The IR channel draws its receivers' noise in blocks: every slot gets exactly what
    ``rng.standard_normal((2, m, k))`` called for that slot gives, in order, across the block's
    ends (a slot larger than a block too)."""
    from petswarm_env.comms import ir_channel

    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    channel = IRChannel(world, cfg.ir, np.random.default_rng(9))
    want = np.random.default_rng(9)
    k = cfg.ir.num_receivers
    sizes = [4, 1, 9, 4] * 40 + [ir_channel._NOISE_BLOCK // k, 3]  # beyond two blocks; one slot larger than a block
    for m in sizes:
        z = channel._slot_noise(m, k)
        assert z.shape == (2, m, k)
        assert z.tobytes() == want.standard_normal((2, m, k)).tobytes()
