"""Whole episodes hashed against golden values (tests/golden/episodes.json).

The golden values were recorded before the restructure of issue 13; a change that alters behaviour
on purpose regenerates them (``python -m tests.golden.episodes --regenerate``) in the same commit
and says why.
"""

import json

import pytest

from tests.golden.episodes import CASES, GOLDEN_PATH, run_case

GOLDEN = json.loads(GOLDEN_PATH.read_text())


def test_the_golden_file_covers_every_case():
    assert set(GOLDEN) == set(CASES)
    assert len(CASES) >= 7


@pytest.mark.parametrize("name", sorted(CASES))
def test_episode_is_bit_identical_to_its_golden_hash(name):
    got = run_case(name)
    want = GOLDEN[name]
    assert got["steps"] == want["steps"]
    assert got["formation_rmse_m"] == want["formation_rmse_m"]
    assert got["sha256"] == want["sha256"], f"{name}: the episode changed (regenerate only for a change on purpose)"
