"""A swarm standing still for protocol tests: the user stands (its walk starts after 100 s), every
member starts at its slot, and the agents send zero actions."""

import numpy as np

import petswarm_env

STILL = {"user.start_delay_s": 100.0, "swarm.spawn": "at_slots"}  # the user stands, the members at their slots


def make(seed=0, **overrides):
    """The env of ``STILL`` with ``overrides``, reset with ``seed``."""
    env = petswarm_env.parallel_env(**{**STILL, **overrides})
    env.reset(seed=seed)
    return env


def run(env, seconds):
    """Step ``seconds`` of episode time with zero actions (fewer if every agent left)."""
    for _ in range(int(round(seconds / env.cfg.control_period_s))):
        if not env.agents:
            return
        env.step({a: np.zeros(3, np.float32) for a in env.agents})


def assert_tables_agree(env, totals: bool = True):
    """Every slave of the swarm holds the master's member and neighbour tables (learned from frames),
    and with ``totals`` the member count that goes with them."""
    master = env.episode.swarm.master
    for idx in env.episode.swarm.slave_ids():
        node = env.episode.fleet.nodes[idx]
        assert node.know.members == master.know.members, f"robot {idx} holds other member tables"
        assert node.formation.links == master.formation.links
        if totals:
            assert node.know.total_members == len(master.know.members)
