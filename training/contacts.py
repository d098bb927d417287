"""Where a slave policy's contacts happen, on a comparison grid's cells
(``python -m petswarm.training.contacts --grid configs/eval/heldout_recurrent.yaml --policies scripted,learned``).

The grid counts contacts (a contact is one pymunk ``begin`` between a robot and another robot, a
user or a wall: :class:`petswarm_env.sim.world.CollisionCounts`); this tool says which. Each
policy drives every cell's seeds as the grid does (:func:`petswarm.evaluation.runner.run_episode`),
and every contact that begins is recorded with the step it began in and, for each robot in it, its
role (``master``, ``slave``, ``waiting``, ``other``: :meth:`petswarm_env.metrics.Experimenter.roles`)
and — for a slave in slave-role driving — the phase of the step it acted in: *lost* (no fresh IR
fix of anyone, :meth:`petswarm.training.warm_start.TeacherLabels.lost`), *building* (its true
formation error above ``building_error_m``) or *holding*; and whether the swarm's formation had been
built yet (``building_time_s`` set). Ground truth is read for the record only, as in evaluation.

A contact's *kind* names its pair: ``slave-slave``, ``slave-master``, ``slave-user``, ``slave-wall``,
``slave-waiting``, ``slave-other`` and the same without a slave (``master-user``, …); the *slave
phase* of a contact is the worst phase of its driving slaves (lost > building > holding); printed with ``*`` when the formation had not
been built yet (the episode's building phase). A diagnosis
for training (docs/training.md), not a benchmark.
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from typing import Any

import numpy as np

from petswarm.evaluation.evaluate import make_team
from petswarm.evaluation.grid_spec import load_grid
from petswarm.evaluation.runner import run_episode
from petswarm.training.warm_start import TeacherLabels
from petswarm_env.config import load_config
from petswarm_env.env import PetSwarmEnv
from petswarm_env.sim.body import COLLISION_ROBOT, COLLISION_USER, COLLISION_WALL
from petswarm_env.files import write_json_atomic

PHASE_ORDER = ("holding", "building", "lost")


class ContactLog:
    """Records every contact that begins in ``env``'s current episode (call :meth:`attach` after each
    reset) with the state of the step it began in (:meth:`step_state`, called with each step's infos
    and observations before the policy's actions are applied)."""

    def __init__(self, env: PetSwarmEnv, building_error_m: float = 0.3):
        self.env, self.building_error_m = env, building_error_m
        self.contacts: list[dict[str, Any]] = []
        self._state: dict[int, str] = {}
        self._built = False
        self._label: TeacherLabels | None = None

    def attach(self) -> None:
        env = self.env
        world = env.unwrapped.episode.world if hasattr(env, "unwrapped") else env.episode.world
        counts = world.collisions

        def on(kind: str):
            def begin(arbiter, space, data):  # the world's own handler counts, this one records
                {"rr": world._on_robot_robot, "ru": world._on_robot_user, "rw": world._on_robot_wall}[kind](arbiter, space, data)
                a, b = arbiter.shapes
                bodies = [("robot", a.robot_index)] + ([("robot", b.robot_index)] if kind == "rr" else [(kind, None)])
                self._record(bodies)
            return begin

        space = world.space
        space.on_collision(COLLISION_ROBOT, COLLISION_ROBOT, begin=on("rr"))
        space.on_collision(COLLISION_ROBOT, COLLISION_USER, begin=on("ru"))
        space.on_collision(COLLISION_ROBOT, COLLISION_WALL, begin=on("rw"))
        self._label = TeacherLabels(env)
        self._counts = counts

    def step_state(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]]) -> None:
        """The phase of every driving slave in the step about to be taken (by robot index)."""
        env, state = self.env, {}
        for agent in env.active_agents:
            if self._label.lost(observations[agent]):
                state[env.agent_robot(agent)] = "lost"
            else:
                err = infos[agent]["formation_error_m"]
                state[env.agent_robot(agent)] = "building" if err > self.building_error_m else "holding"
        self._state = state
        self._built = math.isfinite(env.episode.metrics.building_time_s)
        self._roles = env.truth.roles()

    def _record(self, bodies: list[tuple[str, int | None]]) -> None:
        names, phases = [], []
        for what, i in bodies:
            if what != "robot":
                names.append({"ru": "user", "rw": "wall"}[what])
                continue
            role = self._roles[i] if i < len(self._roles) else "waiting"
            names.append(role)
            if role == "slave" and i in self._state:
                phases.append(self._state[i])
        order = {"slave": 0, "master": 1, "waiting": 2, "other": 3, "user": 4, "wall": 5}
        kind = "-".join(sorted(names, key=lambda n: order[n]))
        phase = max(phases, key=PHASE_ORDER.index) if phases else "none"
        self.contacts.append({"step": self.env.num_cycles, "kind": kind, "phase": phase, "built": self._built})


def trace(env: PetSwarmEnv, team, seed: int, building_error_m: float = 0.3) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """One episode of ``team`` on ``env`` as the grid runs it; its summary and its contacts."""
    log = ContactLog(env, building_error_m)

    class Traced:  # the team, with the contact log's view of each step before it acts
        def reset(self, s=None):
            team.reset(s)
            log.attach()
            self._infos = None

        def act_all(self, obs):
            infos = self._infos or {a: {"formation_error_m": 0.0} for a in obs}
            log.step_state(obs, infos)
            return team.act_all(obs)

    traced = Traced()

    def on_step(infos):
        traced._infos = infos

    summary = run_episode(env, traced, seed, on_step=on_step)
    return summary, log.contacts


def trace_grid(grid_path: str, policies: list[str], episodes: int | None = None, seed: int | None = None,
               progress=print) -> dict[str, Any]:
    grid = load_grid(grid_path, load_config(), episodes=episodes, seed=seed)
    seeds = grid.seeds()
    out: dict[str, Any] = {"grid": grid_path, "seeds": seeds, "cells": []}
    for cell in grid.cells:
        row: dict[str, Any] = {"name": cell.name, "policies": {}}
        for policy in policies:
            env = PetSwarmEnv(cell.config)
            team = make_team(env, policy, {}, seeds[0])
            eps = []
            for s in seeds:
                summary, contacts = trace(env, team, s)
                counted = sum(summary["collisions"].values())
                eps.append({"seed": s, "collisions": counted, "contacts": contacts,
                            "formation_hold_rmse_m": summary["formation_hold_rmse_m"]})
            env.close()
            row["policies"][policy] = eps
        out["cells"].append(row)
        if progress:
            progress(format_cell(row))
    return out


def tally(eps: list[dict[str, Any]]) -> Counter:
    c: Counter = Counter()
    for e in eps:
        for k in e["contacts"]:
            c[(k["kind"], k["phase"] + ("" if k["built"] else "*"))] += 1
    return c


def paired_difference(cells: list[dict[str, Any]], candidate: str, reference: str, resamples: int = 10_000,
                      seed: int = 0) -> dict[str, Any]:
    """The candidate's contacts less the reference's over all cells' episodes (each episode pairs the
    two on one seed) and its 95 % stratified-bootstrap interval (episodes resampled within each cell,
    as the grid's intervals are): whether a difference of counts is more than the episodes' draw."""
    diffs = [np.array([e["collisions"] - r["collisions"] for e, r in zip(c["policies"][candidate], c["policies"][reference])], float)
             for c in cells]
    rng = np.random.default_rng(seed)
    boot = np.zeros(resamples)
    for d in diffs:
        if len(d):
            boot += d[rng.integers(0, len(d), (resamples, len(d)))].sum(1)
    total = int(sum(d.sum() for d in diffs))
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return {"candidate": candidate, "reference": reference, "difference": total, "ci95": [float(lo), float(hi)],
            "episodes": int(sum(len(d) for d in diffs))}


def hold_ratios(cells: list[dict[str, Any]], candidate: str, reference: str) -> list[float]:
    """Each cell's ratio of the candidate's mean ``formation_hold_rmse_m`` to the reference's over the
    episodes where both built (as the grid scores a cell); NaN for a cell with none."""
    out = []
    for c in cells:
        pairs = [(e["formation_hold_rmse_m"], r["formation_hold_rmse_m"]) for e, r in zip(c["policies"][candidate], c["policies"][reference])]
        pairs = [(x, y) for x, y in pairs if x is not None and y is not None and math.isfinite(x) and math.isfinite(y)]
        out.append(sum(x for x, _ in pairs) / sum(y for _, y in pairs) if pairs else math.nan)
    return out


def format_cell(row: dict[str, Any]) -> str:
    parts = []
    for policy, eps in row["policies"].items():
        t = tally(eps)
        total = sum(e["collisions"] for e in eps)
        per_seed = ",".join(str(e["collisions"]) for e in eps)
        detail = " ".join(f"{k}/{p}:{n}" for (k, p), n in sorted(t.items(), key=lambda x: -x[1]))
        parts.append(f"{policy} {total} [{per_seed}] {detail}")
    return f"{row['name']:<22} " + "  |  ".join(parts)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m petswarm.training.contacts", description=__doc__.split("\n\n")[0])
    ap.add_argument("--grid", default="configs/eval/heldout_recurrent.yaml")
    ap.add_argument("--policies", default="scripted,learned", help="comma-separated policy names or files "
                                                                 "(privileged-teacher: the teacher); the first is the reference "
                                                                 "the others' paired differences are taken to")
    ap.add_argument("--episodes", type=int, default=None, help="seeds per cell (default: the grid's)")
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    policies = [p.strip() for p in a.policies.split(",") if p.strip()]
    out = trace_grid(a.grid, policies, a.episodes, a.seed)
    totals = {p: tally([e for c in out["cells"] for e in c["policies"][p]]) for p in policies}
    for p, t in totals.items():
        print(f"all cells, {p}: {sum(t.values())} contacts: "
              + " ".join(f"{k}/{ph}:{n}" for (k, ph), n in sorted(t.items(), key=lambda x: -x[1])))
    for p in policies[1:]:
        diff = paired_difference(out["cells"], p, policies[0])
        out.setdefault("differences", []).append(diff)
        ratios = [r for r in hold_ratios(out["cells"], p, policies[0]) if math.isfinite(r)]
        diff["hold_ratio_median"] = float(np.median(ratios)) if ratios else math.nan
        print(f"{p} less {policies[0]}: {diff['difference']:+d} contacts over {diff['episodes']} paired episodes, "
              f"95 % CI [{diff['ci95'][0]:+.0f}, {diff['ci95'][1]:+.0f}] (stratified bootstrap over the episodes); "
              f"hold ratio median over the cells {diff['hold_ratio_median']:.2f}")
    if a.json:
        write_json_atomic(a.json, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
