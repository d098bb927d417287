"""Layout 3 against layout 2 (issue 15): every golden case hashed with each observation cut to
layout 2's 67 values, its rewards, terminations, truncations, the truth and the summary.

Run it on the tree before and after the change (each with its own tree first on PYTHONPATH, and
NumPy's AVX-512 kernels off as the golden episodes are: ``NPY_DISABLE_CPU_FEATURES``) and compare
the two JSON outputs: equal ``v2_sha256`` = the old fields and everything else bit-identical.
``new_fields_all_one`` says the added fields (the ring's presence and location-known flags) read
1.0 throughout: a petbot carries the whole virtual ring.

    PYTHONPATH=$PWD python -m tests.golden.compare_v2_fields > v2.json
"""
import hashlib, json, struct, sys
import numpy as np
from tests.golden import episodes as g

def run(name):
    import petswarm_env
    overrides, policy_name, seed, steps = g.CASES[name]
    env = petswarm_env.parallel_env(**{**overrides, "max_cycles": steps})
    policy = g._policy(policy_name, env, seed)
    h = hashlib.sha256(); extra_ok = True
    def add_obs(obs):
        nonlocal extra_ok
        for a in sorted(obs):
            h.update(a.encode()); o = np.ascontiguousarray(obs[a], dtype=np.float32)
            h.update(o[:67].tobytes())
            if o.size > 67: extra_ok &= bool((o[67:] == 1.0).all())
    def add_truth():
        c, t = g._truth(env); h.update(c.tobytes()); h.update(t.tobytes())
    obs, _ = env.reset(seed=seed); policy.reset(seed); add_obs(obs); add_truth()
    while env.agents:
        obs, r, te, tr, _ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        add_obs(obs)
        for a in sorted(r):
            h.update(a.encode()); h.update(struct.pack("<d??", float(r[a]), bool(te[a]), bool(tr[a])))
        add_truth()
    h.update(json.dumps(env.episode_summary(), sort_keys=True, default=float).encode())
    return {"v2_sha256": h.hexdigest(), "obs_size": int(env.layout.size), "new_fields_all_one": extra_ok}

print(json.dumps({n: run(n) for n in g.CASES}, sort_keys=True))
