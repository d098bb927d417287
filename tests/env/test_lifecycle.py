"""The agent lifecycle (petswarm_env/episode.py, env.py): every possible agent is an agent from
reset — a robot not (yet, or no longer) in slave-role driving waits with a zero observation and
``active`` 0, and turns active under the same id whenever it is a slave again — only a robot off for
good is terminated (it never comes back in that episode), and the observations after a step hold
only agents a caller may act for. On every shipped scenario × every
fault kind, without wrappers: PettingZoo's ``parallel_api_test``, the README's loop, TorchRL's
``PettingZooWrapper`` (``use_mask=True``, its setting for a varying agent set) and RLlib's
``ParallelPettingZooEnv`` with RLlib's own episode bookkeeping."""

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
EARLIER = 5.0  # the matrix runs each scenario's own faults and arrivals this many times earlier (arrival 25 s -> 5 s)


def _env(scenario: str, kind: str, max_cycles: int = MAX_CYCLES, *, earlier: float = 1.0, **overrides):
    """``scenario`` with its own faults (and arrivals), times divided by ``earlier``, and one
    transient ``kind`` fault on a random slave early on."""
    sc = SCENARIOS[scenario]
    faults = [{**f, "at_s": f["at_s"] / earlier} for f in sc.faults] + [{**TRANSIENT, "kind": kind}]
    arrivals = [{**a, "at_s": a["at_s"] / earlier} for a in sc.arrivals]
    return petswarm_env.parallel_env(**{"user.scenario": scenario, "faults": faults, "arrivals": arrivals,
                                        "max_cycles": max_cycles, **overrides})


# chosen: an arrival's recruitment takes up to this long. In the matrix's arrival case the formation
# builds in ~3.6 s and the user walks off before the arrival turns up (5 s); a walking master recruits
# only within the organize's region around itself (middleware/recovery.py, refill_region_m), so the
# arrival joins ~4 s after it turns up, once the walking swarm comes near (when the formation built in
# ~4.8 s and the user walked off ~1.2 s later, it joined ~1 s after it turned up, within the 8 s)
ARRIVAL_JOIN_S = 6.0


def _matrix_cycles(scenario: str) -> int:
    sc = SCENARIOS[scenario]
    if sc.changes_master:
        return 200  # mode_change hands over at ~17 s
    last = max((a["at_s"] / EARLIER for a in sc.arrivals), default=0.0)
    return max(MAX_CYCLES, int(round((last + ARRIVAL_JOIN_S) / 0.1)))


def _torchrl_rollout(raw, steps: int):
    """TorchRL's stock ``PettingZooWrapper`` straight around the env (no FixedAgents), through an
    auto-reset; every waiting agent's row is zeros and the agents' rows are masked as env.agents."""
    import torch
    from torchrl.envs import PettingZooWrapper

    env = PettingZooWrapper(env=raw, use_mask=True, done_on_any=False, return_state=True)
    scripted = make_policy("scripted", PolicySpec.from_env(raw))

    def policy(td):  # the scripted slave on every row (a waiting agent's action is ignored by the env)
        obs = td["robot", "observation"].numpy()
        acts = [scripted.act(a, obs[i]) for i, a in enumerate(env.group_map["robot"])]
        td["robot", "action"] = torch.as_tensor(np.stack(acts))
        return td

    td = env.rollout(steps, policy=policy, break_when_any_done=False)
    obs, active = td["next", "robot", "observation"], td["next", "robot", "info", "active"].bool()
    assert not obs[~active].any() and obs[active].abs().sum(-1).gt(0).all()
    assert int(td["next", "done"].sum()) >= 1 and td["robot", "mask"][0].all()
    return td


def _rllib_episode(raw, policy):
    """RLlib's ParallelPettingZooEnv straight around the env, its steps fed to RLlib's own
    MultiAgentEpisode (what its env runners do): agents that join, leave or are truncated."""
    from ray.rllib.env.multi_agent_episode import MultiAgentEpisode
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    env = ParallelPettingZooEnv(raw)
    obs, infos = env.reset(seed=0)
    episode = MultiAgentEpisode()
    episode.add_env_reset(observations=obs, infos=infos)
    done = False
    while not done:
        actions = policy.act_all(obs)
        obs, rewards, terms, truncs, infos = env.step(actions)
        episode.add_env_step(observations=obs, actions=actions, rewards=rewards, infos=infos, terminateds=terms, truncateds=truncs)
        done = terms["__all__"] or truncs["__all__"]
    assert episode.is_done
    return episode


@pytest.mark.parametrize("kind", FAULT_KINDS)
@pytest.mark.parametrize("scenario", sorted(SCENARIOS))
def test_every_adapter_takes_the_raw_env_on_every_scenario_and_fault_kind(scenario, kind):
    pytest.importorskip("torchrl")
    pytest.importorskip("ray")
    cycles = _matrix_cycles(scenario)
    env = _env(scenario, kind, cycles, earlier=EARLIER)
    parallel_api_test(env, num_cycles=cycles)
    observations, _ = env.reset(seed=1)  # the README's loop (README.md, "Python quickstart")
    assert set(env.agents) == set(env.possible_agents)  # every possible agent from reset on
    policy = make_policy("scripted", PolicySpec.from_env(env))
    while env.agents:
        observations, rewards, terminations, truncations, infos = env.step(policy.act_all(observations))
    summary = env.episode_summary()
    assert summary["faults_injected"] >= 1 + len(SCENARIOS[scenario].faults)
    # the arrival joined (a waiting agent became active), or the open slot went to the robot the transient
    # fault had taken out, recruited again after its reboot first (the master's periodic scan takes either)
    rejoined = [ids for _, what, ids in env.episode.swarm.member_log if what == "joined"]
    assert summary["arrivals_joined"] == len(SCENARIOS[scenario].arrivals) or (SCENARIOS[scenario].arrivals and rejoined)
    _torchrl_rollout(env, cycles + 10)
    _rllib_episode(env, policy)


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
def test_a_slave_back_from_a_transient_fault_is_an_agent_again_under_its_own_id(kind):
    """The faulty slave leaves slave-role driving without a termination, waits (zeros, ``active``
    0), and once the master's scan recruits it again it is active again and driven by the policy:
    a member nobody drove stood in its slot as an obstacle its neighbours followed."""
    env = _env("straight", kind, max_cycles=150)
    steps = _run(env)
    ep = env.episode
    left = [(i, a) for i, (before, after, obs, _, terms, truncs, infos) in enumerate(steps)
            for a in before if a in after and infos[a]["active"] == 0 and (i == 0 or steps[i - 1][6][a]["active"] == 1)]
    assert len(left) == 1  # the faulty slave left slave-role driving ...
    i, agent = left[0]
    assert not steps[i][4][agent]  # ... not terminated: it waits
    assert not steps[i][2][agent].any()  # with a zero observation
    back = [k for k in range(i + 1, len(steps)) if steps[k][6][agent]["active"] == 1]
    assert back, "the swarm recruited it again after the reboot"
    robot = env.agent_robot(agent)
    assert robot in ep.swarm.slave_ids() and steps[-1][6][agent]["active"] == 1 and not ep.left
    assert np.abs(steps[back[-1]][2][agent]).sum() > 0  # its own observation again


def test_a_robot_off_for_good_is_terminated_and_never_returns():
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "max_cycles": 150,
                                       "faults": [{"at_s": 1.0, "robot": "random_slave", "kind": "dead"}]})
    steps = _run(env)
    ended = [(i, a) for i, (before, _, _, _, terms, truncs, _) in enumerate(steps) for a in before if terms[a]]
    assert len(ended) == 1
    i, agent = ended[0]
    assert agent not in steps[i][2] and all(agent not in after for _, after, *_ in steps[i:])
    assert env.episode.left == {agent}


def test_an_agent_that_becomes_the_master_waits_with_its_reward_and_no_termination():
    """mode_change: the slave that becomes the master leaves slave-role driving; the step gives its
    reward and no termination (it may be a slave again after another change), and from then on a
    zero observation with ``active`` 0; observations and infos hold exactly the agents a caller may
    act for (every agent in ``agents``; on the last step every truncated one)."""
    env = petswarm_env.parallel_env(**{"user.scenario": "mode_change", "max_cycles": 400})
    left = []
    for before, after, obs, rewards, terms, truncs, infos in _run(env):
        joined = set(after) - set(before)
        assert set(rewards) == set(terms) == set(truncs) == set(before) | joined
        truncated = all(truncs.values())
        assert set(obs) == set(infos) == (set(before) | joined if truncated else set(after))
        assert not any(terms.values())
        left += [a for a in before if a in after and infos[a]["active"] == 0 and isinstance(rewards[a], float)
                 and a in env.possible_agents and np.abs(obs[a]).sum() == 0 and a not in left and a != "robot_0"]
    assert len(left) == 1  # the new master
    assert env.episode_summary()["events"]["master_changes"] == 1


@pytest.mark.parametrize("scenario, kind", [("mode_change", None), ("dropout", "dead")])
def test_rllibs_parallel_pettingzoo_env_and_its_episode_bookkeeping_take_the_raw_env(scenario, kind):
    """At the scenarios' own times: mode_change's old master and dropout's arrival wait from reset
    and join mid-episode; one slave leaves."""
    pytest.importorskip("ray")
    raw = _env(scenario, kind, max_cycles=400) if kind else petswarm_env.parallel_env(**{"user.scenario": scenario, "max_cycles": 400})
    episode = _rllib_episode(raw, make_policy("scripted", PolicySpec.from_env(raw)))
    assert len(episode.agent_episodes) == 5  # mode_change: robot_0 waits, then joins; dropout: the arrival robot_5


def test_torchrls_pettingzoo_wrapper_sees_the_waiting_agent_join():
    """mode_change: robot_0 (the master at reset) is a waiting agent (zeros, active 0, its actions
    ignored) until the master change makes it a slave; the slave that became the master waits
    from then on (inactive, still in the agents: TorchRL's mask stays full)."""
    pytest.importorskip("torchrl")
    raw = petswarm_env.parallel_env(**{"user.scenario": "mode_change", "max_cycles": 250})
    td = _torchrl_rollout(raw, 250)
    row = raw.possible_agents.index("robot_0")
    active, mask = td["next", "robot", "info", "active"].bool(), td["next", "robot", "mask"]
    joined = int(active[:, row].float().argmax())
    assert 100 < joined < 249 and not active[:joined, row].any() and active[joined:-1, row].all()
    assert int(mask[-2].sum()) == len(raw.possible_agents)  # nobody left the agents
    assert int(active[-2].sum()) == len(raw.possible_agents) - 1  # the new master waits


def test_the_benchs_loop_acts_only_for_live_agents_past_a_slave_leaving():
    """bench/loops.EnvLoop feeds every observation back as actions: 1 + 16 slaves, seed 0, a slave
    leaves at step 544 (it raised KeyError when the step's observations held the agent that left)."""
    from petswarm.bench.loops import EnvLoop

    loop = EnvLoop(16, "scripted", 0)
    loop.run(steps=560)
    assert loop.steps == 560
