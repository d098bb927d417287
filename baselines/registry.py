"""Slave policies by name: ``make_policy("scripted" | "random" | "learned" | PATH, spec)``.

The one place that knows every policy class. It imports :mod:`petswarm.baselines.policy` (the interface)
and the implementations; none of them imports it back.
"""

from __future__ import annotations

from petswarm.baselines.leader_follower import LeaderFollowerPolicy
from petswarm.baselines.learned import LearnedPolicy, shipped_policy_path
from petswarm.baselines.policy import Policy, PolicySpec, RandomPolicy

POLICY_NAMES = ("scripted", "random", "learned")


def make_policy(name: str, spec: PolicySpec, seed: int = 0) -> Policy:
    """``scripted`` (the leader–follower reference), ``random``, ``learned`` (the shipped model)
    or the path of a saved policy file (``.npz``)."""
    if name == "scripted":
        return LeaderFollowerPolicy(spec)
    if name == "random":
        return RandomPolicy(spec, seed)
    if name == "learned":
        return LearnedPolicy.load(shipped_policy_path(), spec)
    if name.endswith(".npz") or "/" in name:
        return LearnedPolicy.load(name, spec)
    raise ValueError(f"unknown policy '{name}'; choose scripted, random, learned or the path of a .npz policy file")
