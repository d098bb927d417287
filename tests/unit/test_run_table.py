"""The run table's summary line (evaluation/commands.py) names lost-robot episodes when there are
any (petswarm_env/metrics.py: a slave >= LOST_M from its reference point for >= LOST_S once built)."""

from petswarm.evaluation.commands import format_run_table
from petswarm.evaluation.runner import summarize


def _episode(seed: int, lost_s: float) -> dict:
    return {"seed": seed, "slaves": 4, "formation_rmse_m": 0.5, "building_time_s": 7.0, "formation_hold_rmse_m": 0.14,
            "refill_settle_rmse_m": float("nan"), "lost_robot_s": lost_s, "organize_time_s": 1.0, "join_retries": 0,
            "token_recoveries": 0, "slaves_missing": 0, "collisions": {"robot_robot": 0, "robot_user": 0, "robot_wall": 0},
            "frames": {"sent": 10, "lost": 0, "collided": 0}}


def test_the_summary_line_counts_lost_robot_episodes_only_when_there_are_some():
    lost = summarize([_episode(0, 0.0), _episode(1, 6.5), _episode(2, 4.9)])
    assert lost["lost_robot_episodes"] == 1
    line = format_run_table({"episodes": [], "summary": lost}).splitlines()[-1]
    assert "1 lost-robot episode(s)" in line
    quiet = summarize([_episode(0, 0.0), _episode(1, 2.0)])
    assert quiet["lost_robot_episodes"] == 0
    assert "lost-robot" not in format_run_table({"episodes": [], "summary": quiet})
