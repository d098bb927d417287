"""The agent lifecycle (petswarm_env/episode.py): an agent that is terminated never comes back
under the same id in that episode, and the observations after a step hold only agents a caller
may act for. PettingZoo's ``parallel_api_test`` runs on the raw env (no wrapper) on every shipped
scenario with a transient fault of every kind, and the README's loop runs on each."""

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.config import FAULT_KINDS
from petswarm_env.scenarios import SCENARIOS

MAX_CYCLES = 80  # 8 s: a fault at 1 s for 3 s, the reboot and the master's scan take the robot back by then
TRANSIENT = {"at_s": 1.0, "robot": "random_slave", "duration_s": 3.0}


def _env(scenario: str, kind: str, max_cycles: int = MAX_CYCLES, **overrides):
    """``scenario`` with its own faults and one transient ``kind`` fault on a random slave early on."""
    faults = [dict(f) for f in SCENARIOS[scenario].faults] + [{**TRANSIENT, "kind": kind}]
    return petswarm_env.parallel_env(**{"user.scenario": scenario, "faults": faults, "max_cycles": max_cycles, **overrides})


@pytest.mark.parametrize("kind", FAULT_KINDS)
@pytest.mark.parametrize("scenario", sorted(SCENARIOS))
def test_parallel_api_test_and_the_readme_loop_pass_without_wrappers(scenario, kind):
    env = _env(scenario, kind)
    parallel_api_test(env, num_cycles=MAX_CYCLES)
    observations, _ = env.reset(seed=1)  # the README's loop (README.md, "Using the environment")
    policy = make_policy("scripted", PolicySpec.from_env(env))
    while env.agents:
        observations, rewards, terminations, truncations, infos = env.step(policy.act_all(observations))
    assert env.episode_summary()["faults_injected"] >= 1


def _run(env, seed=0):
    """One scripted episode; per step: (agents before, agents after, the step's five dicts)."""
    obs, _ = env.reset(seed=seed)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    steps = []
    while env.agents:
        before = list(env.agents)
        out = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        obs = out[0]
        steps.append((before, list(env.agents), *out))
    return steps


@pytest.mark.parametrize("kind", ["dead", "radio_silent"])
def test_a_slave_back_from_a_transient_fault_stays_out_of_the_agents_and_stands_still(kind):
    env = _env("straight", kind, max_cycles=150)
    steps = _run(env)
    ep = env.episode
    gone = [a for before, after, _, _, terms, truncs, _ in steps for a in before if terms[a] and not truncs[a]]
    assert len(gone) == 1  # the faulty slave left the agents
    robot = env.agent_robot(gone[0])
    assert robot in ep.swarm.slave_ids()  # the swarm recruited it again after the reboot ...
    assert all(gone[0] not in after for _, after, *_ in steps[next(i for i, s in enumerate(steps) if gone[0] in s[4] and s[4][gone[0]]):])
    assert np.allclose(env.truth.robots[robot].velocity_body, 0.0, atol=1e-6)  # ... and holds it still: no driver
    assert gone[0] in ep.left


def test_terminated_agents_get_reward_and_termination_but_no_observation():
    """mode_change: the slave that becomes the master is terminated; the step gives its reward and
    termination, and observations and infos only for the agents a caller may act for."""
    env = petswarm_env.parallel_env(**{"user.scenario": "mode_change", "max_cycles": 400})
    ended = 0
    for before, after, obs, rewards, terms, truncs, infos in _run(env):
        joined = set(after) - set(before)
        assert set(rewards) == set(terms) == set(truncs) == set(before) | joined
        truncated = all(truncs.values())
        assert set(obs) == set(infos) == (set(before) | joined if truncated else set(after))
        for a in before:
            if terms[a]:
                ended += 1
                assert a not in obs and isinstance(rewards[a], float)
    assert ended == 1  # the new master
    assert env.episode_summary()["events"]["master_changes"] == 1


@pytest.mark.parametrize("scenario, kind", [("mode_change", None), ("dropout", "dead")])
def test_rllibs_parallel_pettingzoo_env_and_its_episode_bookkeeping_take_the_raw_env(scenario, kind):
    """RLlib's ParallelPettingZooEnv straight around the env, its steps fed to RLlib's own
    MultiAgentEpisode (what its env runners do): agents that join, leave or are truncated."""
    pytest.importorskip("ray")
    from ray.rllib.env.multi_agent_episode import MultiAgentEpisode
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    raw = _env(scenario, kind, max_cycles=400) if kind else petswarm_env.parallel_env(**{"user.scenario": scenario, "max_cycles": 400})
    env = ParallelPettingZooEnv(raw)
    policy = make_policy("scripted", PolicySpec.from_env(raw))
    obs, infos = env.reset(seed=0)
    episode = MultiAgentEpisode()
    episode.add_env_reset(observations=obs, infos=infos)
    done = False
    while not done:
        actions = policy.act_all(obs)
        obs, rewards, terms, truncs, infos = env.step(actions)
        episode.add_env_step(observations=obs, actions=actions, rewards=rewards, infos=infos, terminateds=terms, truncateds=truncs)
        done = terms["__all__"] or truncs["__all__"]
    assert episode.is_done and len(episode.agent_episodes) == 5  # mode_change: robot_0 joins; dropout: the arrival robot_5


def test_torchrls_pettingzoo_wrapper_takes_the_raw_env_when_every_agent_is_there_at_reset():
    """TorchRL's PettingZooWrapper (use_mask=True) reads every possible agent's observation at reset:
    it takes the raw env where no agent joins later (no master change, no arrival), through
    transient faults and auto-resets; elsewhere FixedAgents (petswarm_env/wrappers.py)."""
    pytest.importorskip("torchrl")
    from torchrl.envs import PettingZooWrapper

    env = PettingZooWrapper(env=_env("straight", "dead", max_cycles=150), use_mask=True, done_on_any=False, return_state=True)
    # the robots stand (zero actions): random ones would drive members out of the swarm's reach, removed as
    # astray (middleware/recovery.py), and torch's unseeded draws would make the count differ run to run
    td = env.rollout(320, policy=lambda td: td.update(env.full_action_spec.zero()), break_when_any_done=False)
    mask = td["robot", "mask"].sum(-1)
    assert int(mask.max()) == 4 and int(mask.min()) == 3 and int(td["next", "done"].sum()) == 2


def test_the_benchs_loop_acts_only_for_live_agents_past_a_slave_leaving():
    """bench/loops.EnvLoop feeds every observation back as actions: 1 + 16 slaves, seed 0, a slave
    leaves at step 544 (it raised KeyError when the step's observations held the agent that left)."""
    from petswarm.bench.loops import EnvLoop

    loop = EnvLoop(16, "scripted", 0)
    loop.run(steps=560)
    assert loop.steps == 560
