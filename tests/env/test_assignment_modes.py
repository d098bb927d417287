"""swarm.assignment through the whole environment: both RUTA modes organize the default swarm (seeds
0-4) and build its formation, and a slave learns its slot only from frames in both."""

import numpy as np
import pytest

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from tests.protocol.test_join import slaves_consistent
from tests.protocol.test_knowledge_in_frames import CUSTOM, MASTER, _NoSwarmSection, _per_robot_configs

MODES = ["ruta_centralized", "ruta_decentralized"]


@pytest.mark.parametrize("mode", MODES)
def test_both_modes_organize_the_full_default_swarm(mode):
    for seed in range(5):
        env = petswarm_env.parallel_env(**{"swarm.assignment": mode})
        env.reset(seed=seed)
        (s,) = env.organize_summary()
        assert s["slaves_missing"] == 0 and len(s["members"]) == 5, (seed, s)
        assert env.swarm.organize_result.complete
        slaves_consistent(env)


@pytest.mark.parametrize("mode", MODES)
def test_the_swarm_builds_its_formation_with_ruta(mode):
    env = petswarm_env.parallel_env(max_cycles=300, **{"swarm.assignment": mode})
    policy = make_policy("scripted", PolicySpec.from_env(env), 0)
    obs, _ = env.reset(seed=0)
    policy.reset(0)
    for _ in range(300):
        obs, _, term, trunc, _ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        if not env.agents:
            break
    summary = env.episode_summary()
    assert summary["formation_rmse_m"] < 1.0, summary["formation_rmse_m"]


@pytest.mark.parametrize("mode", MODES)
def test_slaves_without_a_swarm_section_take_their_ruta_slot_from_the_frames(monkeypatch, mode):
    _per_robot_configs(monkeypatch, _NoSwarmSection)  # a slave reading cfg.swarm fails the test
    env = petswarm_env.parallel_env(max_cycles=50, **{**CUSTOM, "user.scenario": "straight", "swarm.assignment": mode})
    env.reset(seed=0)
    sw = env.swarm
    assert len(sw.slave_ids()) == 4 and sw.master.node_id == MASTER
    for nid in sw.slave_ids():
        assert env.fleet.nodes[nid].formation.links == sw.formation.links
    assert np.isfinite(env.organize_summary()[0]["organize_time_s"])


@pytest.mark.parametrize("mode", MODES)
def test_ruta_organizes_the_same_way_for_the_same_seed(mode):
    got = []
    for _ in range(2):
        env = petswarm_env.parallel_env(**{"swarm.assignment": mode, "radio.loss_prob": 0.1})
        env.reset(seed=3)
        (s,) = env.organize_summary()
        got.append((s["organize_time_s"], s["members"], s["join_retries"], env.radio.stats.frames_sent))
    assert got[0] == got[1]
