"""Knowledge travels in frames (seed 000 §3.4 Fig. 8, §3.5 Table 3).

A slave's member table, neighbour table with its offsets, formation shape and driving mode come
only from the joining notification and the mode-change frames it received — never from its own
configuration's formation, never from the shared per-user ``Swarm``.
"""

import dataclasses

import numpy as np
import pytest

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.config import load_config
from petswarm_env.middleware import fleet as fleet_mod
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import build_formation, formation_for_mode
from petswarm_env.middleware.modes import ModeManager

# a shape no standard formation has: two robots beside the master, each with one behind it
CUSTOM = {
    "swarm.formation": "custom",
    "swarm.custom_links": [
        {"robot": 1, "neighbour": 0, "offset_m": [0.0, 1.0]},
        {"robot": 2, "neighbour": 0, "offset_m": [0.0, -1.0]},
        {"robot": 3, "neighbour": 1, "offset_m": [-1.0, 0.0]},
        {"robot": 4, "neighbour": 2, "offset_m": [-1.0, 0.0]},
    ],
}
MASTER = 0  # the first user's robot: the master of the default scenario


class _NoSwarmSection:
    """A robot's configuration without its ``swarm`` section: reading it is the leak."""

    def __init__(self, cfg):
        self._cfg = cfg

    def __getattr__(self, name):
        if name == "swarm":
            raise AssertionError("a slave's middleware read its configuration's formation (cfg.swarm)")
        return getattr(self._cfg, name)


def _per_robot_configs(monkeypatch, slave_cfg):
    """The master's node gets the env's configuration, every other robot's node ``slave_cfg``."""
    node_class = fleet_mod.Node

    def node(index, cfg, *args):
        return node_class(index, cfg if index == MASTER else slave_cfg(cfg), *args)

    monkeypatch.setattr(fleet_mod, "Node", node)


def _drive(env, steps, seed=0):
    policy = make_policy("scripted", PolicySpec.from_env(env), seed)
    obs, _ = env.reset(seed=seed)
    policy.reset(seed)
    errors = []
    for _ in range(steps):
        obs, _, _, _, infos = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        errors.append(np.mean([i["formation_error_m"] for i in infos.values()]))
    return errors


@pytest.mark.parametrize("slave_cfg", [
    lambda cfg: load_config(overrides={"swarm.formation": "column"}),  # a formation of their own
    _NoSwarmSection,  # no formation at all
], ids=["slaves configured for a column", "slaves without a swarm section"])
def test_slaves_take_the_slots_of_a_formation_only_the_master_knows(monkeypatch, slave_cfg):
    _per_robot_configs(monkeypatch, slave_cfg)
    env = petswarm_env.parallel_env(max_cycles=200, **{**CUSTOM, "user.scenario": "straight"})
    errors = _drive(env, 200)
    sw = env.episode.swarm
    assert len(sw.slave_ids()) == 4 and sw.master.node_id == MASTER
    custom = formation_for_mode(env.cfg.swarm, 5, "following")
    assert sw.formation.links == custom.links
    for nid in sw.slave_ids():
        node = env.episode.fleet.nodes[nid]
        assert node.formation.links == custom.links and node.formation.shape == "custom"
        assert node.know.mode == "following" and node.know.members == sw.master.know.members
    assert np.mean(errors[-50:]) < 0.3  # in their slots of the custom shape (a column's would be ≈ 1.4 m off)


def _mode_change_until_heard(monkeypatch, handler, heard: list):
    """The mode_change scenario (seed 0) with every ModeManager's ``_on_mode_change`` replaced by
    ``handler(env, original, manager, frame)``, stepped until ``heard`` holds something."""
    original, built = ModeManager._on_mode_change, []
    monkeypatch.setattr(ModeManager, "_on_mode_change", lambda self, frame: handler(built[0], original, self, frame))
    built.append(petswarm_env.parallel_env(max_cycles=400, **{"user.scenario": "mode_change"}))
    env = built[0]
    env.reset(seed=0)
    while env.agents and not heard:
        env.step({})
    assert heard, "the scenario changes the driving mode"


def test_a_slave_hearing_the_mode_change_does_not_change_the_swarms_mode(monkeypatch):
    """The driving mode is the master's decision: the swarm drives in the new mode once its master
    committed the change, not when the first slave applied the frame (which sets the slave's own
    knowledge only)."""
    heard = []

    def spy(env, original, self, frame):
        original(self, frame)
        if self.node.state == "slave":
            heard.append((frame.payload["mode"], self.node.know.mode, env.episode.swarm.mode))

    _mode_change_until_heard(monkeypatch, spy, heard)
    new, known, swarm_mode = heard[0]
    assert known == new == "leading" and swarm_mode == "following"


def test_a_slave_left_out_of_the_new_tables_keeps_what_it_knows(monkeypatch):
    """A mode change whose tables do not list the slave that hears it (the master removed it as
    lost and its removal notice was lost) changes nothing the slave knows; before, the slave looked
    its member number up in the tables and the episode stopped with StopIteration."""
    seen = []

    def left_out(env, original, self, frame):
        if self.node.state == "slave" and not seen:
            before = (dict(self.node.know.members), self.node.know.member, self.node.know.mode, self.last_seq)
            members = {m: n for m, n in frame.payload["members"].items() if n != self.node.node_id}
            original(self, dataclasses.replace(frame, payload={**frame.payload, "members": members}))
            seen.append((before, (dict(self.node.know.members), self.node.know.member, self.node.know.mode, self.last_seq)))
            return
        original(self, frame)

    _mode_change_until_heard(monkeypatch, left_out, seen)
    before, after = seen[0]
    assert after == before


def test_the_tables_frames_are_sized_by_their_content():
    cfg = load_config()
    wedge = build_formation(cfg.swarm, 5)
    payload = {"members": {m: m for m in range(5)}, "links": wedge.links_payload()}
    assert msg.payload_bytes(msg.JOIN_NOTIFY, payload) == 7 + 2 * 5 + 6 * 4
    assert msg.payload_bytes(msg.MODE_CHANGE, payload) == 6 + 2 * 5 + 6 * 4
    assert msg.payload_bytes(msg.SCAN, {"known": [3, 4]}) == 4 + 2 * 2
    assert msg.payload_bytes(msg.TOKEN, {"seq": 1, "next": 2}) == msg.SIZE_BYTES[msg.TOKEN]
    assert msg.payload_bytes(msg.JOIN_NOTIFY, payload) <= msg.MAX_PAYLOAD_BYTES
    assert set(msg.SIZE_BYTES) >= set(msg.PER_ENTRY_BYTES)
