"""The grid's fair statistics (evaluation/stats.py): paired ratios with bootstrap intervals, the
probability of improvement, the interquartile mean and the stratified bootstrap over cells."""

import math

import numpy as np
import pytest

from petswarm.evaluation.grid import compare_runs
from petswarm.evaluation.stats import (interquartile_mean, paired_ratio, probability_of_improvement,
                              stratified_ratio_aggregates)


def test_paired_ratio_uses_the_seeds_where_both_have_a_value():
    r = paired_ratio([1.0, 2.0, 3.0, math.nan, 2.0], [2.0, 2.0, 4.0, 1.0, 3.0])
    assert r["n"] == 4 and r["ratio"] == pytest.approx(8 / 11)
    lo, hi = r["ci95"]
    assert lo <= r["ratio"] <= hi and hi - lo > 0
    assert paired_ratio([1.0, 2.0, 3.0, math.nan, 2.0], [2.0, 2.0, 4.0, 1.0, 3.0]) == r  # a fixed stream: deterministic
    one = paired_ratio([1.0], [2.0])
    assert one["ratio"] == 0.5 and all(math.isnan(x) for x in one["ci95"])  # one pair: no interval
    assert math.isnan(paired_ratio([math.nan], [1.0])["ratio"])


def test_a_clear_difference_gives_an_interval_that_excludes_one():
    rng = np.random.default_rng(1)
    ref = 0.2 + 0.02 * rng.standard_normal(10)
    r = paired_ratio(0.5 * ref, ref)
    assert r["ci95"][1] < 1.0 and r["ratio"] == pytest.approx(0.5)


def test_probability_of_improvement_counts_lower_as_better_with_ties_half():
    assert probability_of_improvement([1.0, 2.0, 3.0], [2.0, 2.0, 4.0]) == pytest.approx(6 / 9)
    assert probability_of_improvement([0.1, 0.1], [1.0, 2.0]) == 1.0
    assert probability_of_improvement([5.0], [1.0]) == 0.0
    assert math.isnan(probability_of_improvement([], [1.0]))


def test_interquartile_mean_drops_the_outer_quarters():
    assert interquartile_mean([1, 2, 3, 4, 100, 5, 6, -50]) == pytest.approx(np.mean([2, 3, 4, 5]))


def test_stratified_aggregates_over_cells():
    cells = [([0.5, 0.6, 0.55], [1.0, 1.1, 1.0]), ([1.0, 1.0], [1.0, 1.0]), ([0.4, 0.5], [1.0, 1.0]),
             ([3.0, 3.0], [1.0, 1.0]), ([math.nan], [1.0])]  # the last has no pair: left out
    agg = stratified_ratio_aggregates(cells)
    assert agg["cells"] == 4
    ratios = [1.65 / 3.1, 1.0, 0.45, 3.0]
    assert agg["ratio_iqm"] == pytest.approx(interquartile_mean(ratios))
    lo, hi = agg["ratio_iqm_ci95"]
    assert lo <= agg["ratio_iqm"] <= hi
    assert agg["p_improvement"] == pytest.approx((1.0 + 0.5 + 1.0 + 0.0) / 4)


def _run(values, key="formation_hold_rmse_m", collisions=0, built=None, **extra):
    eps = [{key: v, "formation_rmse_m": v, **{k: x[i] for k, x in extra.items()}} for i, v in enumerate(values)]
    return {"per_episode": eps, "collisions": collisions,
            "formations_built": sum(math.isfinite(v) for v in values) if built is None else built}


def test_a_cell_verdict_uses_the_scored_ratio_and_every_guard():
    good, ref = _run([0.05, 0.06, 0.07]), _run([0.1, 0.1, 0.1])
    v = compare_runs(good, ref, False, "formation_hold_rmse_m", 0.8, 0.1)
    assert v["score_ratio"] == pytest.approx(0.6) and v["meets_target"] and v["others_no_worse"] is None
    assert not compare_runs(_run([0.05, 0.06, 0.07], collisions=1), ref, False, "formation_hold_rmse_m", 0.8, 0.1)["meets_target"]
    # an episode that never built is no better: fewer formations built fails the cell
    assert not compare_runs(_run([0.05, 0.06, math.nan]), ref, False, "formation_hold_rmse_m", 0.8, 0.1)["meets_target"]


def test_a_mixed_cell_is_judged_on_the_candidates_own_error_with_the_others_guarded():
    own = {"mix_robots_hold_rmse_m": [0.05, 0.05], "others_hold_rmse_m": [0.1, 0.1]}
    ref_own = {"mix_robots_hold_rmse_m": [0.1, 0.1], "others_hold_rmse_m": [0.1, 0.1]}
    cand, ref = _run([0.09, 0.09], **own), _run([0.1, 0.1], **ref_own)  # the team ratio 0.9 would fail; the robot's own is 0.5
    v = compare_runs(cand, ref, True, "formation_hold_rmse_m", 0.8, 0.1)
    assert v["score_metric"] == "mix_robots_hold_rmse_m" and v["score_ratio"] == pytest.approx(0.5)
    assert v["others_no_worse"] and v["meets_target"]
    worse = _run([0.09, 0.09], mix_robots_hold_rmse_m=[0.05, 0.05], others_hold_rmse_m=[0.12, 0.12])
    v = compare_runs(worse, ref, True, "formation_hold_rmse_m", 0.8, 0.1)
    assert v["others_no_worse"] is False and not v["meets_target"]


def test_with_the_candidate_driving_the_team_its_own_error_is_the_other_robots():
    """One reference robot among the candidate's: the candidate robots are the others; the
    reference robot (the mix) is the guarded one."""
    cand = _run([0.09, 0.09], mix_robots_hold_rmse_m=[0.1, 0.1], others_hold_rmse_m=[0.05, 0.05])
    ref = _run([0.1, 0.1], mix_robots_hold_rmse_m=[0.1, 0.1], others_hold_rmse_m=[0.1, 0.1])
    v = compare_runs(cand, ref, True, "formation_hold_rmse_m", 0.8, 0.1, candidate_in_mix=False)
    assert v["score_metric"] == "others_hold_rmse_m" and v["score_ratio"] == pytest.approx(0.5) and v["meets_target"]
    dragged = _run([0.09, 0.09], mix_robots_hold_rmse_m=[0.2, 0.2], others_hold_rmse_m=[0.05, 0.05])
    v = compare_runs(dragged, ref, True, "formation_hold_rmse_m", 0.8, 0.1, candidate_in_mix=False)
    assert v["others_no_worse"] is False and not v["meets_target"]  # the reference robot held twice as badly


def test_the_building_time_has_its_ratio_and_interval_on_the_seeds_where_both_built():
    cand = _run([0.1, 0.1, 0.1], building_time_s=[4.0, 6.0, math.nan])
    ref = _run([0.1, 0.1, 0.1], building_time_s=[8.0, 12.0, 9.0])
    v = compare_runs(cand, ref, False, "formation_hold_rmse_m", 0.8, 0.1)
    assert v["building_ratio"] == pytest.approx(0.5)  # (4 + 6) / (8 + 12): the third seed has no pair
    assert v["building_ratio_ci95"] == pytest.approx([0.5, 0.5])  # both pairs are 0.5: every resample is


def test_a_lost_robot_episode_the_reference_does_not_also_have_fails_the_cell():
    """A slave LOST_S or longer at least LOST_M from its reference point (petswarm_env/metrics.py) on a
    seed where the reference lost none: listed, and the cell misses its target whatever its ratio."""
    ref = _run([0.1, 0.1, 0.1], lost_robot_s=[0.0, 6.0, 0.0], seed=[7, 8, 9])
    both = _run([0.05, 0.05, 0.05], lost_robot_s=[0.0, 9.0, 4.9], seed=[7, 8, 9])  # lost on 8, as the reference was
    v = compare_runs(both, ref, False, "formation_hold_rmse_m", 0.8, 0.1)
    assert v["lost_only_candidate"] == [] and v["no_new_lost"] and v["meets_target"]
    new = _run([0.05, 0.05, 0.05], lost_robot_s=[5.0, 0.0, 0.0], seed=[7, 8, 9])
    v = compare_runs(new, ref, False, "formation_hold_rmse_m", 0.8, 0.1)
    assert v["lost_only_candidate"] == [7] and not v["no_new_lost"] and not v["meets_target"]
    assert v["score_ratio"] == pytest.approx(0.5)
