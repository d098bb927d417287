"""The benchmark's statistics (evaluation/stats.py) against values computed by hand."""

import math

import numpy as np

from petswarm.evaluation.stats import (_interval, _iqm_rows, resample_task, stratified_aggregates, task_aggregates,
                                       worst_for_missing)


def test_iqm_is_the_mean_of_the_middle_half_and_keeps_inf():
    assert _iqm_rows(np.array([8.0, 1, 7, 2, 6, 3, 5, 4])) == 4.5  # (3 + 4 + 5 + 6) / 4
    assert _iqm_rows(np.array([1.0, 2, 3, 100])) == 2.5  # 4 values: one cut at each end
    assert _iqm_rows(np.array([1.0, 2, 3, math.inf])) == 2.5  # a failed episode in the top quarter is trimmed
    assert _iqm_rows(np.array([1.0, 2, math.inf, math.inf])) == math.inf  # half failed: the IQM says so


def test_a_missing_score_is_the_worst():
    assert list(worst_for_missing([0.1, None, float("nan"), "x", 2])) == [0.1, math.inf, math.inf, math.inf, 2.0]


def test_probability_of_improvement_counts_lower_as_better_and_ties_half():
    # candidate {1, 2} vs reference {1.5, 3}: 1<1.5, 1<3, 2<3 better, 2>1.5 worse -> 3/4
    assert task_aggregates([[1.0, 2.0]], [[1.5, 3.0]])["p_improvement"] == 0.75
    assert task_aggregates([[1.0, 1.0]], [[1.0, 1.0]])["p_improvement"] == 0.5
    # never built (+inf) on both sides is a tie; a built episode beats a failed one
    assert task_aggregates([[math.inf, 1.0]], [[math.inf, math.inf]])["p_improvement"] == (0.5 + 0.5 + 1 + 1) / 4


def test_bootstrap_interval_of_two_episodes_is_the_hand_computed_one():
    # one run of scores {0, 1}: a resample's IQM (its mean, 2 values) is 0, 0.5 or 1 with p 1/4, 1/2, 1/4,
    # so the 2.5 % and 97.5 % quantiles are 0 and 1
    r = task_aggregates([[0.0, 1.0]], [[0.5, 0.5]])
    assert r["iqm"] == 0.5 and r["iqm_ci95"] == [0.0, 1.0]
    boot = resample_task(np.array([[0.0, 1.0]]), np.random.default_rng(1), 4000)
    means = boot.mean(axis=1)
    assert abs((means == 0.5).mean() - 0.5) < 0.03 and abs((means == 0).mean() - 0.25) < 0.03


def test_the_bootstrap_draws_training_runs_as_well_as_episodes():
    # two runs, each constant: resampling episodes alone would give a zero-width interval; drawing the runs gives
    # resamples with both runs the same (IQM 0 or 1) a quarter of the time each
    r = task_aggregates([[0.0, 0.0], [1.0, 1.0]], [[1.0, 1.0]])
    assert r["iqm"] == 0.5 and r["iqm_ci95"] == [0.0, 1.0] and r["runs"] == 2 and r["episodes"] == 4


def test_the_interval_is_of_real_resamples_also_with_inf():
    assert _interval(np.array([1.0] * 10 + [math.inf] * 90)) == [1.0, math.inf]
    assert _interval(np.arange(1000.0)) == [24.0, 975.0]  # nearest rank outward of 24.975 and 974.025


def test_pooled_tasks_are_stratified():
    # task A all 0, task B all 1, four scores each: every stratified resample keeps four of each, so the pooled
    # IQM (of 0 0 0 0 1 1 1 1: the middle half 0 0 1 1) is 0.5 in every copy; an unstratified bootstrap would vary
    r = stratified_aggregates([([[0.0, 0, 0, 0]], [[1.0, 1.0]]), ([[1.0, 1, 1, 1]], [[1.0, 1.0]])])
    assert r["tasks"] == 2 and r["iqm"] == 0.5 and r["iqm_ci95"] == [0.5, 0.5]
    assert r["p_improvement"] == 0.75 and r["p_improvement_ci95"] == [0.75, 0.75]  # mean of 1 (A) and 0.5 (B)
    assert stratified_aggregates([])["tasks"] == 0
