"""Whole episodes hashed against golden values (tests/golden/episodes.json).

The golden values were recorded before the code's restructure; a change that alters behaviour
on purpose regenerates them (``python -m tests.golden.episodes --regenerate``) in the same commit
and says why. The cases run in one child process with NumPy's AVX-512 kernels off
(``tests.golden.episodes.portable_environ``), so the hashes hold on AVX-512 and AVX2 machines alike.
"""

import json
import platform

import pytest

from tests.golden.episodes import CASES, GOLDEN_PATH, run_all_portable

GOLDEN = json.loads(GOLDEN_PATH.read_text())

pytestmark = pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"),
                                reason="the golden hashes were recorded with x86-64 (AVX2) NumPy kernels")


@pytest.fixture(scope="module")
def results():
    return run_all_portable()


def test_the_golden_file_covers_every_case():
    assert set(GOLDEN) == set(CASES)
    assert len(CASES) >= 7


@pytest.mark.parametrize("name", sorted(CASES))
def test_episode_is_bit_identical_to_its_golden_hash(name, results):
    got = results[name]
    want = GOLDEN[name]
    assert got["steps"] == want["steps"]
    assert got["formation_rmse_m"] == want["formation_rmse_m"]
    assert got["sha256"] == want["sha256"], f"{name}: the episode changed (regenerate only for a change on purpose)"
