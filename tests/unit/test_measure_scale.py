"""measure_scale's summary: which episodes were built before their user walked off, what the
others looked like then, and why an episode was not built with every slave (synthetic rows: the
figures follow from them by hand)."""

import math

from petswarm.experiments.measure_scale import cause, summarize


def _row(seed, building_s, walk_s, off, worst, full=True):
    return {"seed": seed, "joined": True, "organized": True, "building_time_s": building_s, "hold_rmse_m": 0.2,
            "rmse_m": 1.0, "contacts": 1, "round_s": 1.4, "collided": 0.1, "stale_fix_s": 10.0, "astray": 0,
            "walk_s": walk_s, "off_at_walk": off, "worst_at_walk_m": worst,
            "built_full": full and math.isfinite(building_s)}


def test_standing_and_the_slaves_off_when_the_user_walked():
    rows = [
        _row(0, 20.0, 20.0, 0, 0.28),  # built standing: the user walked off when it was built
        _row(1, 45.0, 30.0, 2, 0.6, full=False),  # built while walking, after a member was removed
        _row(2, math.nan, 30.0, 4, 5.0),  # never built
        {"seed": 3, "joined": False, "organized": False, "error": "did not organize"},
    ]
    s = summarize(rows)
    assert (s["episodes"], s["joined"], s["built"], s["full"], s["standing"]) == (4, 1 + 1 + 1, 2, 1, 1)
    assert s["off_at_walk"] == 3.0  # over the two not built standing
    assert math.isclose(s["worst_at_walk_m"], 2.8)
    assert math.isclose(s["building_s"], 32.5)


def test_why_an_episode_was_not_built_with_every_slave():
    """Each episode not built with every slave gets the first cause that fits, and the summary counts them."""
    unjoined = {"seed": 9, "joined": False, "organized": False, "error": "did not organize"}
    cascade = _row(4, math.nan, 30.0, 5, 3.0) | {"astray": 3}
    removed = _row(5, 40.0, 30.0, 2, 0.8, full=False) | {"astray": 1}
    straggler = _row(6, math.nan, 30.0, 1, 5.4)
    short = _row(7, math.nan, 30.0, 6, 1.3)
    just_short = _row(8, math.nan, 30.0, 2, 0.9)
    built = _row(0, 20.0, 20.0, 0, 0.28)
    late = _row(1, 45.0, 30.0, 2, 0.6)  # built with every slave while the user walked: not a failure
    assert [cause(r) for r in (unjoined, cascade, removed, straggler, short, just_short, built, late)] == [
        "unjoined", "cascade", "removed", "straggler", "short", "short", None, None]
    assert summarize([built, short, cascade, short, unjoined])["why"] == {"cascade": 1, "short": 2, "unjoined": 1}
