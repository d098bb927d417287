"""experiments/reassignment.py (issue 15 part 5) is written against the faults branch's ``faults``
key; until it exists the experiment says so (NotAvailable) instead of making up a number."""

import pytest

from experiments import reassignment
from experiments.registry import EXPERIMENTS
from experiments.results import NotAvailable
from petswarm_env.config import Config, load_config


@pytest.mark.skipif("faults" in Config.model_fields, reason="the faults branch is merged: register and run it")
def test_without_faults_it_is_not_available_and_not_registered():
    with pytest.raises(NotAvailable, match="faults"):
        reassignment.run(load_config(), 0, True, lambda done, total: None)
    assert "reassignment" not in EXPERIMENTS


def test_its_trials_are_the_dropout_scenario_in_a_four_slave_swarm():
    o = reassignment.overrides("ruta_centralized")
    assert o["swarm.num_slaves"] == 4 and o["user.scenario"] == "dropout"
    assert reassignment.FAULT == {"at_s": 20.0, "robot": "random_slave", "kind": "dead"}
    assert o["max_cycles"] * 0.1 >= 30.0
