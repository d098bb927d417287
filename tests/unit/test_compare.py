"""training/compare.py: the grid's cells and the summary against the reference policy."""

from petswarm.training.compare import cells, compare, label, summary


def test_the_grid_is_every_formation_in_both_modes_and_the_extra_cells():
    grid = cells()
    assert len(grid) == 12 and {"swarm.formation": "row", "swarm.mode": "leading"} in grid
    assert label({"swarm.num_slaves": 2}) == "num_slaves=2"


def test_compare_runs_each_policy_on_the_same_cells_and_reuses_figures():
    grid = [{"swarm.num_slaves": 2}]
    reused = {"scripted": {"formation_rmse_m": 0.5, "collisions": 1, "episodes": 1, "wall_time_s": 0.0}}
    rows = compare(["scripted", "random"], grid, ["zigzag"], 1, 5000, 10, progress=lambda _: None,
                   reuse={"num_slaves=2": reused})
    assert rows[0]["policies"]["scripted"] == reused["scripted"]  # taken, not re-run
    assert rows[0]["policies"]["random"]["episodes"] == 1
    text = summary(rows, ["scripted", "random"])
    assert text.startswith("random: geometric mean") and "1 for scripted" in text
