"""The control arbiter's ultrasonic safety stage (seed 001): the shipped plain-Python stage against its numpy form."""

import numpy as np
from tests import oracles


def test_safety_stage_equals_the_numpy_formulation():
    from petswarm_env.control.arbiter import SafetyStage

    rng = np.random.default_rng(5)
    stage = SafetyStage(8, 0.35, 0.3, 2.0)
    changed = 0
    for _ in range(500):
        cmd = tuple(rng.uniform(-1.5, 1.5, 3))
        ranges = rng.uniform(0.05, 2.0, 8) if rng.random() < 0.7 else np.full(8, 2.0)
        want, got = oracles.safety_filter(stage, cmd, ranges), stage.filter(cmd, ranges)
        assert (want is None) == (got is None)
        if want is not None:
            changed += 1
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert 50 < changed < 500
