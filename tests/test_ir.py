"""Tests for the IR relative-location module (seed 000 §3.3, §4.3)."""


import numpy as np
import pydantic
import pytest

from experiments.ir_accuracy import (
    PAPER_ANGLES_DEG,
    PAPER_DIRECTION_RMSE_DEG,
    PAPER_DISTANCE_RMSE_CM,
    PAPER_DISTANCES_M,
    PAPER_SAMPLES_PER_POINT,
    accuracy_experiment,
)
from petswarm_env.config import IRConfig, load_config
from petswarm_env.middleware import ir
from petswarm_env.sim.geometry import wrap_angle


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
