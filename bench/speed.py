"""The speed measurements: petswarm ``env.step`` (:func:`bench_petswarm`), the physics floor
(:func:`bench_floor`), the MPE peer (:func:`bench_mpe`) and petswarm against MPE in alternating
bursts (:func:`bench_side_by_side`)."""

from __future__ import annotations

import gc
import math
import time

import numpy as np

from petswarm.bench.loops import EnvLoop, MPELoop
from petswarm.bench.settings import BenchSettings
from petswarm_env.config import load_config
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.sim.world import World


def bench_petswarm(num_slaves: int, policy_name: str, s: BenchSettings) -> dict:
    loop = EnvLoop(num_slaves, policy_name, s.seed)
    loop.run(steps=s.warmup_steps)
    loop.clear()
    gc.collect()
    loop.run(seconds=s.target_s, min_steps=s.min_steps)
    # time a few more resets if the measurement saw fewer than 3 (their cost is reported apart)
    extra = 0
    while loop.resets + extra < 3:
        t0 = time.perf_counter()
        loop.env.reset(seed=loop.next_seed + extra)
        loop.reset_s += time.perf_counter() - t0
        extra += 1
    resets = loop.resets + extra
    return {
        "name": f"petswarm_{policy_name}_{num_slaves}",
        "kind": "petswarm",
        "label": f"petswarm {policy_name} (1+{num_slaves})",
        "policy": policy_name,
        "slaves": num_slaves,
        "agents": num_slaves + 1,
        "steps": loop.steps,
        "steps_per_s": loop.steps / loop.step_s,
        "agent_steps_per_s": loop.agent_steps / loop.step_s,
        "ms_per_step": 1e3 * loop.step_s / loop.steps,
        "cpu_ms_per_step": 1e3 * loop.step_cpu_s / loop.steps,  # process CPU time: less sensitive to load
        # slaves that joined, per step: a candidate can stay out (join radius vs its RSSI distance estimate)
        "mean_slaves_joined": loop.agent_steps / loop.steps,
        "policy_ms_per_step": 1e3 * loop.policy_s / loop.steps,
        "reset_ms": 1e3 * loop.reset_s / resets,
        "resets": resets,
        "substeps": loop.env.cfg.physics_substeps,
    }


def bench_floor(num_robots: int, s: BenchSettings) -> dict:
    """The env's pymunk bodies stepped with the env's substeps and nothing else: every body's
    velocity and angular velocity set before each substep (pymunk's public setters), then
    ``Space.step``."""
    cfg = load_config()
    world = World(cfg, SCENARIOS[cfg.user.scenario].script(cfg.user, np.random.default_rng(s.seed)))
    spacing = cfg.swarm.spacing_m
    cols = 4
    for i in range(num_robots):  # a grid behind the user, spaced like a formation: no contacts
        world.add_robot((-1.0 - spacing * (i // cols), spacing * (i % cols - (cols - 1) / 2)), 0.0)
    space = world.space
    bodies = [r.body for r in world.robots] + [u.body for u in world.users]
    substeps, dt = cfg.physics_substeps, world.dt_sub
    speed, turn = 0.8, 0.5  # every body drives the same circle: the group stays in the arena, no contacts
    steps = 0

    def run(n: int) -> float:
        nonlocal steps
        t0 = time.perf_counter()
        for _ in range(n):
            a = turn * cfg.control_period_s * steps
            vel = (speed * math.cos(a), speed * math.sin(a))
            for _ in range(substeps):
                for b in bodies:
                    b.velocity = vel
                    b.angular_velocity = 0.0
                space.step(dt)
            steps += 1
        return time.perf_counter() - t0

    run(s.warmup_steps)
    gc.collect()
    elapsed, done, chunk = 0.0, 0, 100
    while elapsed < s.target_s or done < s.min_steps:
        elapsed += run(chunk)
        done += chunk
    # for reference: the same space stepped with no velocity writes at all
    bare_elapsed, bare_done = 0.0, 0
    while bare_elapsed < s.target_s / 3 or bare_done < s.min_steps:
        t0 = time.perf_counter()
        for _ in range(chunk * substeps):
            space.step(dt)
        bare_elapsed += time.perf_counter() - t0
        bare_done += chunk
    return {
        "name": f"floor_{num_robots}",
        "kind": "floor",
        "label": f"physics floor ({num_robots} bodies)",
        "agents": num_robots,
        "steps": done,
        "steps_per_s": done / elapsed,
        "agent_steps_per_s": num_robots * done / elapsed,
        "ms_per_step": 1e3 * elapsed / done,
        "substeps": substeps,
        "contacts": world.collisions.total(),
        "bare_steps_per_s": bare_done / bare_elapsed,  # Space.step only, no velocity writes
    }


def mpe_available() -> tuple[bool, str]:
    try:
        from mpe2 import simple_spread_v3  # noqa: F401
    except ImportError as exc:
        return False, f"mpe2 is not installed ({exc}); install the bench extra: pip install -e '.[bench]'"
    return True, ""


def bench_mpe(n_agents: int, s: BenchSettings, max_cycles: int) -> dict:
    """MPE simple_spread parallel_env, N agents, random continuous actions (generated outside the
    timed call), resets timed apart."""
    loop = MPELoop(n_agents, s.seed, max_cycles)
    loop.run(steps=s.warmup_steps)
    loop.clear()
    gc.collect()
    loop.run(seconds=s.target_s, min_steps=s.min_steps)
    loop.env.close()
    out = {
        "name": f"mpe_simple_spread_{n_agents}",
        "kind": "mpe",
        "label": f"MPE simple_spread N={n_agents}",
        "agents": n_agents,
        "steps": loop.steps,
        "steps_per_s": loop.steps / loop.step_s,
        "agent_steps_per_s": loop.agent_steps / loop.step_s,
        "ms_per_step": 1e3 * loop.step_s / loop.steps,
        "cpu_ms_per_step": 1e3 * loop.step_cpu_s / loop.steps,
        "policy_ms_per_step": 1e3 * loop.policy_s / loop.steps,
        "max_cycles": max_cycles,
    }
    if loop.resets:
        out["reset_ms"] = 1e3 * loop.reset_s / loop.resets
        out["resets"] = loop.resets
    return out


def bench_side_by_side(s: BenchSettings, max_cycles: int, num_slaves: int = 5) -> dict:
    """petswarm 1+``num_slaves`` (scripted) and MPE simple_spread N=``num_slaves`` + 1 timed in
    alternating bursts of ``side_by_side_burst_s`` of env.step time, ``side_by_side_rounds`` each:
    a change in the machine's speed during the run (a shared machine, CPU frequency) falls on both,
    which measurements minutes apart do not guarantee. The ratio of steps per second over all bursts,
    and per round (its spread)."""
    ps = EnvLoop(num_slaves, "scripted", s.seed)
    mpe = MPELoop(num_slaves + 1, s.seed, max_cycles)
    ps.run(steps=s.warmup_steps)
    mpe.run(steps=s.warmup_steps)
    ps.clear()
    mpe.clear()
    gc.collect()
    per_round = []
    for k in range(s.side_by_side_rounds):
        first, second = (ps, mpe) if k % 2 == 0 else (mpe, ps)  # alternate which goes first
        marks = {id(lp): (lp.steps, lp.step_s) for lp in (ps, mpe)}
        for lp in (first, second):
            lp.run(seconds=lp.step_s + s.side_by_side_burst_s, min_steps=lp.steps + 1)
        rate = {id(lp): (lp.steps - marks[id(lp)][0]) / (lp.step_s - marks[id(lp)][1]) for lp in (ps, mpe)}
        per_round.append(rate[id(ps)] / rate[id(mpe)])
    mpe.env.close()
    return {
        "petswarm": f"scripted 1+{num_slaves}",
        "mpe": f"simple_spread N={num_slaves + 1}",
        "rounds": s.side_by_side_rounds,
        "burst_s": s.side_by_side_burst_s,
        "petswarm_steps": ps.steps,
        "mpe_steps": mpe.steps,
        "petswarm_ms_per_step": 1e3 * ps.step_s / ps.steps,
        "petswarm_cpu_ms_per_step": 1e3 * ps.step_cpu_s / ps.steps,
        "mpe_ms_per_step": 1e3 * mpe.step_s / mpe.steps,
        "mpe_cpu_ms_per_step": 1e3 * mpe.step_cpu_s / mpe.steps,
        "ratio": (ps.steps / ps.step_s) / (mpe.steps / mpe.step_s),
        "ratio_cpu": (ps.steps / ps.step_cpu_s) / (mpe.steps / mpe.step_cpu_s),
        "per_round": per_round,
    }
