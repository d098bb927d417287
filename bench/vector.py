"""Many envs in one process: petswarm's batched vector env (``petswarm_env.vector_env``) at several
sizes, the single ``parallel_env`` and VMAS ``simple_spread`` (where ``vmas`` is installed), timed
side by side in rotating bursts (:func:`bench_vector_side_by_side`).

Every system is driven by uniform random actions drawn outside the timed call (VMAS's own
benchmarks do the same), one thread each (``torch.set_num_threads(1)`` for VMAS), and counted in
*env-steps*: one step of one env copy, so a ``vector_env(64).step`` is 64 env-steps. The vector
env's auto-resets happen inside its ``step`` and are timed with it (their CPU time is also counted
apart: ``auto_reset_cpu_us_per_env_step``); the single env's resets are timed apart, as in the
other measurements; VMAS is never reset (its episodes have no end here). Per-core figures divide
by this process's CPU time (``time.process_time``), which other processes' load disturbs less
than wall time.
"""

from __future__ import annotations

import gc
import time
from typing import Any

import numpy as np

from petswarm.bench.loops import EnvLoop
from petswarm.bench.settings import BenchSettings, log


def vmas_available() -> tuple[bool, str]:
    try:
        import vmas  # noqa: F401
    except ImportError as exc:
        return False, f"vmas is not installed ({exc}); install the bench extra: pip install -e '.[bench]'"
    return True, ""


class _Burst:
    """One system under test: ``burst(seconds)`` steps it until ``seconds`` more of step time,
    accumulating wall time, CPU time and env-steps."""

    label: str
    num_envs: int

    def __init__(self) -> None:
        self.wall_s = self.cpu_s = 0.0
        self.env_steps = self.calls = 0

    def _one(self) -> None:
        raise NotImplementedError

    def burst(self, seconds: float) -> tuple[int, float, float]:
        steps0, wall0, cpu0 = self.env_steps, self.wall_s, self.cpu_s
        perf, cpu = time.perf_counter, time.process_time
        while self.wall_s - wall0 < seconds or self.calls == 0:
            self._prepare()
            t0, c0 = perf(), cpu()
            self._one()
            self.wall_s += perf() - t0
            self.cpu_s += cpu() - c0
            self.env_steps += self.num_envs
            self.calls += 1
        return self.env_steps - steps0, self.wall_s - wall0, self.cpu_s - cpu0

    def _prepare(self) -> None:
        """Untimed work before a step (draw the actions, reset a finished single env)."""

    def clear(self) -> None:
        self.wall_s = self.cpu_s = 0.0
        self.env_steps = self.calls = 0

    def close(self) -> None:
        pass


class SingleEnv(_Burst):
    """``parallel_env`` of 1 master + ``num_slaves`` slaves, random actions; resets untimed."""

    def __init__(self, num_slaves: int, seed: int):
        super().__init__()
        self.loop = EnvLoop(num_slaves, "random", seed)
        self.label = f"petswarm parallel_env 1+{num_slaves}"
        self.num_envs = 1
        self._actions: dict | None = None

    def _prepare(self) -> None:
        if self.loop._over():
            self.loop._reset()
        self._actions = self.loop._actions()

    def _one(self) -> None:
        self.loop._step(self._actions)


class VectorEnv(_Burst):
    """``vector_env(num_envs)`` of 1 master + ``num_slaves`` slaves, random actions for every slot
    (an inactive slot's action is ignored), auto-resets inside the timed step."""

    def __init__(self, num_envs: int, num_slaves: int, seed: int):
        super().__init__()
        import petswarm_env

        self.venv = petswarm_env.vector_env(num_envs, **{"swarm.num_slaves": num_slaves})
        t0 = time.perf_counter()
        obs, _ = self.venv.reset(seed=seed)
        self.reset_s = time.perf_counter() - t0
        self.auto_reset_cpu_s = 0.0  # the CPU time of the auto-resets inside the timed steps
        start = self.venv._start

        def timed_start(n, obs):
            c0 = time.process_time()
            try:
                return start(n, obs)
            finally:
                self.auto_reset_cpu_s += time.process_time() - c0

        self.venv._start = timed_start
        self.rng = np.random.default_rng(seed)
        self.shape = obs.shape[:2] + (3,)
        self.label = f"petswarm vector_env({num_envs}) 1+{num_slaves}"
        self.num_envs = num_envs
        self._actions: np.ndarray | None = None

    def _prepare(self) -> None:
        self._actions = self.rng.uniform(-1.0, 1.0, self.shape).astype(np.float32)

    def _one(self) -> None:
        self.venv.step(self._actions)

    def clear(self) -> None:
        super().clear()
        self.auto_reset_cpu_s = 0.0

    def close(self) -> None:
        self.venv.close()


class VMASEnv(_Burst):
    """VMAS ``simple_spread`` with ``n_agents`` agents, ``num_envs`` envs on the CPU, one torch
    thread, continuous random actions."""

    def __init__(self, num_envs: int, n_agents: int, seed: int):
        super().__init__()
        import torch
        import vmas

        torch.set_num_threads(1)
        self.torch = torch
        self.env = vmas.make_env("simple_spread", num_envs=num_envs, device="cpu", continuous_actions=True,
                                 n_agents=n_agents, seed=seed, max_steps=None)
        self.env.reset()
        self.gen = torch.Generator().manual_seed(seed)
        self.sizes = [self.env.get_agent_action_size(a) for a in self.env.agents]
        self.label = f"VMAS simple_spread N={n_agents}, {num_envs} envs"
        self.num_envs = num_envs
        self._actions: list | None = None

    def _prepare(self) -> None:
        t = self.torch
        self._actions = [t.rand(self.num_envs, k, generator=self.gen) * 2 - 1 for k in self.sizes]

    def _one(self) -> None:
        self.env.step(self._actions)


def bench_vector_side_by_side(s: BenchSettings, verbose: bool = False) -> dict[str, Any]:
    """The single env, ``vector_env`` at each of ``s.vector_envs`` and VMAS simple_spread N=6 with
    ``s.vmas_envs`` envs (if installed), 1 master + 5 slaves, timed in ``s.vector_rounds`` rounds of
    one ``s.vector_burst_s`` burst each, the order rotating from round to round. Per system:
    env-steps/s (wall) and per CPU-second; ratios to the single env in the same run."""
    systems: list[_Burst] = [SingleEnv(5, s.seed)]
    reset_s: dict[str, float] = {}
    for n in s.vector_envs:
        log(verbose, f"vector_env({n}): reset")
        v = VectorEnv(n, 5, s.seed)
        reset_s[v.label] = v.reset_s
        systems.append(v)
    ok, reason = vmas_available()
    if ok and s.vmas_envs:
        systems.append(VMASEnv(s.vmas_envs, 6, s.seed))
    for sys_ in systems:  # warm up, then forget
        sys_.burst(min(0.2, s.vector_burst_s))
        sys_.clear()
    gc.collect()
    per_round: list[dict[str, float]] = []
    for k in range(s.vector_rounds):
        order = systems[k % len(systems):] + systems[: k % len(systems)]
        rates = {}
        for sys_ in order:
            steps, wall, cpu = sys_.burst(s.vector_burst_s)
            rates[sys_.label] = steps / wall
        per_round.append(rates)
        log(verbose, f"vector round {k + 1}/{s.vector_rounds}")
    single = systems[0]
    rows = []
    for sys_ in systems:
        rows.append({
            "label": sys_.label,
            "num_envs": sys_.num_envs,
            "env_steps": sys_.env_steps,
            "calls": sys_.calls,
            "env_steps_per_s": sys_.env_steps / sys_.wall_s,
            "env_steps_per_cpu_s": sys_.env_steps / sys_.cpu_s if sys_.cpu_s > 0 else None,
            "us_per_env_step": 1e6 * sys_.wall_s / sys_.env_steps,
            "vs_single": (sys_.env_steps / sys_.wall_s) / (single.env_steps / single.wall_s),
            "vs_single_cpu": ((sys_.env_steps / sys_.cpu_s) / (single.env_steps / single.cpu_s)
                              if sys_.cpu_s > 0 and single.cpu_s > 0 else None),
            "per_round_vs_single": [r[sys_.label] / r[single.label] for r in per_round],
            "reset_s": reset_s.get(sys_.label),
            # the auto-resets' share of the CPU time per env-step (the vector env's step includes them)
            "auto_reset_cpu_us_per_env_step": (1e6 * sys_.auto_reset_cpu_s / sys_.env_steps
                                               if isinstance(sys_, VectorEnv) else None),
        })
        sys_.close()
    out: dict[str, Any] = {"rows": rows, "rounds": s.vector_rounds, "burst_s": s.vector_burst_s}
    if not ok:
        out["vmas_skipped"] = reason
    return out


def vector_on_same_episodes(num_envs: int, rounds: int, seed: int = 0, steps: int | None = None) -> list[dict[str, float]]:
    """Like with like: ``vector_env(num_envs)`` 1+5 for ``steps`` calls (default: ``max_cycles``, a
    whole episode of every copy; the auto-resets timed apart), then one ``parallel_env`` replaying
    each copy's episodes (their seeds, the copy's actions, from the step each started) one copy after
    the other, its resets outside the timing; uniform random actions. Per round (seeds ``seed``, ``seed + 1``, ...): CPU µs per
    env-step of each without resets, and the auto-resets' apart."""
    import petswarm_env

    venv = petswarm_env.vector_env(num_envs, **{"swarm.num_slaves": 5})
    env = petswarm_env.parallel_env(**{"swarm.num_slaves": 5})
    steps = steps or venv.cfg.max_cycles
    auto, start, cpu = [0.0], venv._start, time.process_time

    def timed_start(n, obs):
        c0 = cpu()
        try:
            return start(n, obs)
        finally:
            auto[0] += cpu() - c0

    venv._start = timed_start
    out = []
    for r in range(rounds):
        venv.reset(seed=seed + r)
        seeds = venv.episode_seeds.copy()
        acts = np.random.default_rng(seed + r).uniform(-1, 1, (steps, num_envs, venv.max_agents, 3)).astype(np.float32)
        starts = [{0: int(s)} for s in seeds]  # per copy: step -> the seed of the episode starting there
        auto[0] = vec_s = 0.0
        for k in range(steps):
            c0 = cpu()
            *_, infos = venv.step(acts[k])
            vec_s += cpu() - c0
            for n, info in enumerate(infos):
                if "finished_seed" in info:
                    starts[n][k + 1] = info["episode_seed"]
        vec_s, auto_s = vec_s - auto[0], auto[0]
        single_s, single_steps = 0.0, 0
        for n in range(num_envs):
            for k in range(steps):
                if k in starts[n]:
                    env.reset(seed=starts[n][k])
                action = {a: acts[k, n, venv._slot[a]] for a in env.agents}
                c0 = cpu()
                env.step(action)
                single_s += cpu() - c0
                single_steps += 1
        out.append({"vector_us": 1e6 * vec_s / (steps * num_envs), "auto_reset_us": 1e6 * auto_s / (steps * num_envs),
                    "single_us": 1e6 * single_s / single_steps, "single_steps": single_steps,
                    "ratio": (single_s / single_steps) / (vec_s / (steps * num_envs))})
    venv.close()
    return out


if __name__ == "__main__":  # python -m petswarm.bench.vector NUM_ENVS [ROUNDS]
    import sys

    if len(sys.argv) not in (2, 3) or not all(x.isdigit() and int(x) > 0 for x in sys.argv[1:]):
        sys.exit("usage: python -m petswarm.bench.vector NUM_ENVS [ROUNDS] (positive integers)")
    for r, row in enumerate(vector_on_same_episodes(int(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) == 3 else 2)):
        print(f"round {r}: vector_env({sys.argv[1]}) {row['vector_us']:.1f} us CPU per env-step without its auto-resets "
              f"({row['auto_reset_us']:.1f} apart); parallel_env on the same episodes and actions {row['single_us']:.1f} us "
              f"({row['single_steps']} steps): vector / single env-steps per CPU-s {row['ratio']:.3f}", flush=True)
