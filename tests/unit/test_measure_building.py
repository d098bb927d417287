"""measure_building's reading of the scripted reference's step-1 branch from a slave's observation."""

import numpy as np

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.experiments.measure_building import branch


def test_branch_follows_the_freshest_fix_the_observation_holds():
    spec = PolicySpec.from_env(petswarm_env.parallel_env())
    sl = spec.layout.slices
    o = np.zeros(spec.layout.size, np.float32)
    assert branch(spec, o) == "1d"  # nothing heard, nothing seen
    o[sl["master.valid"]] = 1.0
    o[sl["master.ir_valid"]] = 1.0
    o[sl["master.ir_age"]] = 1.0  # the master's fix at the end of the age range
    assert branch(spec, o) == "1c"
    o[sl["master.ir_age"]] = 0.2
    assert branch(spec, o) == "1b"
    o[sl["link0.present"]] = 1.0
    o[sl["link0.ir_valid"]] = 1.0
    o[sl["link0.ir_age"]] = 1.0  # a reference's fix too old: still 1b
    assert branch(spec, o) == "1b"
    o[sl["link0.ir_age"]] = 0.2
    assert branch(spec, o) == "1"
