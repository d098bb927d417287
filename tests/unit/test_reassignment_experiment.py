"""experiments/reassignment.py (seed 003 §5.2): its trials' configuration (it runs in
tests/e2e/test_reproduce.py)."""

from petswarm.experiments import reassignment


def test_its_trials_are_the_dropout_scenario_in_a_four_slave_swarm():
    o = reassignment.overrides("ruta_centralized")
    assert o["swarm.num_slaves"] == 4 and o["user.scenario"] == "dropout"
    assert reassignment.FAULT == {"at_s": 20.0, "robot": "random_slave", "kind": "dead"}
    assert o["max_cycles"] * 0.1 >= 30.0
