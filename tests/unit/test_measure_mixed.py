"""experiments/measure_mixed.py: the slot distance is the truth's (the slot of the member number in
the master's table, at the master's true pose), and one short run reports the dead slave, its
removal and the refill."""

import argparse
import math

import petswarm_env
from petswarm.experiments import measure_mixed
from tests.protocol.still import make, run


def test_slot_distances_read_the_masters_table_at_its_true_pose():
    env = make(seed=0)  # the members stand at their slots (jittered 0.3 m)
    d = measure_mixed.slot_distances(env.episode.truth)
    assert sorted(d) == sorted(env.episode.swarm.slave_ids())
    assert all(0.0 <= v <= 0.3 * math.sqrt(2) + 0.05 for v in d.values())
    robot = env.episode.world.robots[1]
    robot.body.position = (robot.position[0] + 7.0, robot.position[1])  # carried 7 m away: 7 m ± its jitter off
    env.episode.world.invalidate_truth()
    assert 6.5 <= measure_mixed.slot_distances(env.episode.truth)[1] <= 7.5


def test_a_short_mixed_run_reports_the_dead_slave_and_the_refill():
    args = argparse.Namespace(fault_at=3.0, arrivals=[4.0, 30.0], spares=0, spare_type="r1", judge_at=10.0, max_cycles=150)
    r = measure_mixed.run(0, "plain", "closest", args)
    assert len(r["dead"]) == 1 and r["removed"][0][1] == r["dead"]  # the dead slave was removed (the ring)
    assert r["refill_s"] <= measure_mixed.REFILL_WITHIN_S  # the r1 arrival took the place
    assert r["arrivals_joined"] == 1 and r["slaves_end"] == 4
    assert measure_mixed.parse_seeds("0-2,5") == [0, 1, 2, 5]
