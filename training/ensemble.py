"""An ensemble of recurrent students (``recurrent.members``), shipped as one recurrent network.

``petswarm train`` with ``recurrent.members: N`` trains N students of the same config, with the seeds
``seed``, ``seed + 1``, ... (each a whole :func:`~petswarm.training.recurrent.train` run in
``member_k/`` of the run folder; ``num_cpus`` of them at a time, each in a process of its own with
one thread, which gives the same weights as one after another), and writes their average as one
policy: the action (a residual's correction) is the mean of the N students' outputs, clipped once.
Why: students of the same config and data budget differ from one training seed to the next as much
as they differ from the scripted reference (docs/training.md), and their errors are not the same
ones; the mean of several is one policy that does not depend on which seed was lucky.

The mean is written as one network of the policy file's recurrent format
(:mod:`petswarm.baselines.learned`, nothing new to read): the members' first encoder layers stacked
(they read the same observation), their later encoder layers, GRU gates and hidden head layers
block-diagonal (each member's units read only its own), and a last layer that averages the members'
outputs. Its step equals the mean of the members' steps up to float32 rounding
(tests/unit/test_ensemble.py).

The run folder: ``member_0/`` … (each member's own run: its policy.npz, last.npz, train_log.json),
``policy.npz`` (the mean of the members' best evaluated students), ``last.npz`` (of their last
ones) and ``train_log.json`` (the members' logs and the mean's evaluation on the config's
evaluation seeds). With ``recurrent.member_checkpoint: last`` ``policy.npz`` is the mean of the last
students and ``members_best.npz`` that of the best: a member's pick among its own evaluations (ten
short episodes each) is noisy enough to keep a student of an early round (docs/training.md). With
``recurrent.keep_members: K`` the policy (and ``last.npz``) is the mean of K members only, those of the
lowest score on a validation grid (training/select_members.py; the log's ``member_validation``), and
``members_all.npz`` the mean of every member; with ``member_checkpoint: validated`` each member's student
is whichever of its best and last scores lower there."""

from __future__ import annotations

import json
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from petswarm.baselines.learned import GRUCell, LearnedPolicy, Recurrent, read_policy, residual_of_meta, save_policy
from petswarm.training.callbacks import LAST_POLICY, evaluate_and_keep, public_log, scripted_reference
from petswarm.training.config import RecurrentConfig, TrainConfig, load_train_config
from petswarm.training.select_members import score_members
from petswarm_env.config import ConfigError
from petswarm_env.files import write_json_atomic

ALL_MEMBERS_POLICY = "members_all.npz"  # with recurrent.keep_members, the mean of every member (beside the chosen ones')
MEMBERS_BEST_POLICY = "members_best.npz"  # with recurrent.member_checkpoint: last, the mean of the members' best evaluated

ALGORITHM = "ensemble of recurrent actors (GRU), each distilled from the privileged teacher by DAgger"


def _block_diagonal(blocks: list[np.ndarray]) -> np.ndarray:
    out = np.zeros((sum(b.shape[0] for b in blocks), sum(b.shape[1] for b in blocks)))
    r = c = 0
    for b in blocks:
        out[r:r + b.shape[0], c:c + b.shape[1]] = b
        r, c = r + b.shape[0], c + b.shape[1]
    return out


def _gates(a: np.ndarray, n: int) -> list[np.ndarray]:
    """A GRU array's three gates ``r, z, n`` (stacked by rows, torch's layout)."""
    return [a[g * n:(g + 1) * n] for g in range(3)]


def merge_students(paths: list[str | Path]) -> tuple[dict[str, Any], list[tuple[np.ndarray, np.ndarray]], Recurrent]:
    """The metadata (the first member's), layers and GRU of one recurrent network whose output is the mean
    of the recurrent policy files ``paths``' outputs (module docstring). The members must share their
    observation layout, activation, residual and sizes of layers (one config, other seeds)."""
    loaded = [read_policy(p) for p in paths]
    meta, first_layers, first = loaded[0]
    if first is None:
        raise ValueError(f"'{paths[0]}' is not a recurrent policy file")
    for p, (m, layers, rec) in zip(paths[1:], loaded[1:]):
        same = (rec is not None and rec.encoder_layers == first.encoder_layers
                and rec.cell.hidden_size == first.cell.hidden_size
                and [w.shape for w, _ in layers] == [w.shape for w, _ in first_layers]
                and all(m.get(k) == meta.get(k) for k in ("observation_layout", "activation", "residual_of", "residual_scale")))
        if not same:
            raise ValueError(f"'{p}' is not a student of the same config as '{paths[0]}' (its layout, sizes or residual differ)")
    k, n, count = first.encoder_layers, first.cell.hidden_size, len(loaded)
    if k < 1:
        raise ValueError("an ensemble needs an encoder layer before the GRU (recurrent.encoder)")

    def f64(a):
        return np.asarray(a, dtype=np.float64)

    layers: list[tuple[np.ndarray, np.ndarray]] = []
    for j in range(k):  # the encoder: the first layer stacked (one observation), the later ones block-diagonal
        ws = [f64(lay[j][0]) for _, lay, _ in loaded]
        layers.append((np.vstack(ws) if j == 0 else _block_diagonal(ws), np.concatenate([f64(lay[j][1]) for _, lay, _ in loaded])))
    cells = [rec.cell for _, _, rec in loaded]
    cell = GRUCell(*(np.vstack([_block_diagonal([_gates(f64(getattr(c, w)), n)[g] for c in cells]) for g in range(3)])
                     for w in ("w_ih", "w_hh")),
                   *(np.concatenate([np.concatenate([_gates(f64(getattr(c, b)), n)[g] for c in cells]) for g in range(3)])
                     for b in ("b_ih", "b_hh")))
    feed = first_layers[k - 1][0].shape[0]  # one member's encoding; the head reads [encodings, hidden states]
    heads = [lay[k:] for _, lay, _ in loaded]
    for j in range(len(heads[0])):
        ws, bs = [f64(h[j][0]) for h in heads], [f64(h[j][1]) for h in heads]
        if j == 0:  # member m's rows read its encoding's and its hidden state's columns
            w = np.zeros((sum(x.shape[0] for x in ws), count * (feed + n)))
            r = 0
            for m, x in enumerate(ws):
                w[r:r + x.shape[0], m * feed:(m + 1) * feed] = x[:, :feed]
                w[r:r + x.shape[0], count * feed + m * n:count * feed + (m + 1) * n] = x[:, feed:]
                r += x.shape[0]
        else:
            w = np.hstack(ws) if j == len(heads[0]) - 1 else _block_diagonal(ws)
        if j == len(heads[0]) - 1:  # the last (linear) layer: the members' mean
            w, b = w / count, np.mean(bs, axis=0)
        else:
            b = np.concatenate(bs)
        layers.append((w, b))
    return meta, layers, Recurrent(k, cell)


def write_merged(paths: list[str | Path], out: str | Path, layout, info: dict[str, Any]) -> None:
    """:func:`merge_students` of ``paths``, written as the recurrent policy file ``out``."""
    meta, layers, rec = merge_students(paths)
    save_policy(out, layers, meta["activation"], layout, info, meta.get("behaviours"), residual_of_meta(meta), rec)


class MemberStopped(RuntimeError):
    """A member's run raised: the message names the member and how to go on (the members that finished are kept)."""


def _run_member(job: tuple[TrainConfig, Path, str], progress) -> dict[str, Any]:
    """One member's whole run; what it raises comes back as :class:`MemberStopped` naming it."""
    from petswarm.training.recurrent import train

    member, folder, command = job
    try:
        return train(member, folder, command=command, progress=progress)
    except Exception as exc:  # noqa: BLE001 - any cause: the message carries its text
        text = " ".join(str(exc).split()) or type(exc).__name__
        raise MemberStopped(f"{folder.name} (seed {member.seed}) stopped: {text}; remove '{folder}' and run the same "
                            f"command again: it keeps the members that finished and trains the others") from None


def _train_member(job: tuple[TrainConfig, Path, str]) -> dict[str, Any]:
    """One member's whole run in a worker process, its progress lines prefixed with its folder."""
    return _run_member(job, lambda line: print(f"[{job[1].name}] {line}", flush=True))


def _same_member(cfg: TrainConfig) -> dict[str, Any]:
    """What a member's weights depend on: its config but the processes at a time and the ensemble's choice of checkpoint
    and of members."""
    defaults = {k: RecurrentConfig.model_fields[k].get_default(call_default_factory=True)
                for k in ("member_checkpoint", "keep_members", "member_grid", "member_seeds")}
    kept = cfg.model_copy(update={"num_cpus": 1, "recurrent": cfg.recurrent.model_copy(update=defaults)})
    return kept.model_dump(mode="json")


def finished_member(cfg: TrainConfig, folder: Path) -> dict[str, Any] | None:
    """The train log of the member ``cfg`` already trained whole in ``folder`` (an ensemble run stopped after some of
    its members finished: :func:`train_ensemble` keeps them), or None where the folder holds no run. A folder with
    another config's run, or one unfinished, is a :class:`ConfigError` that says to remove it: nothing is deleted here."""
    from petswarm.training.recurrent import rounds_for

    if not (folder / "train_log.json").exists():
        return None
    fix = "remove that folder to train this member again (the other members' folders are kept)"
    try:
        log = json.loads((folder / "train_log.json").read_text(encoding="utf-8"))
        done = load_train_config(folder / "train_config.yaml")
    except (OSError, ValueError, ConfigError) as exc:
        raise ConfigError(f"'{folder}' holds a member run that cannot be read ({str(exc).splitlines()[0]}); {fix}") from None
    if _same_member(done) != _same_member(cfg):
        raise ConfigError(f"'{folder}' holds a member run of another config; {fix}")
    if len(log.get("rounds", [])) < rounds_for(cfg) or not all((folder / f).exists() for f in ("policy.npz", LAST_POLICY)):
        rounds = f"{len(log.get('rounds', []))} of {rounds_for(cfg)} rounds"
        raise ConfigError(f"'{folder}' holds an unfinished member run ({rounds}); {fix}")
    return log


def train_ensemble(cfg: TrainConfig, out_dir: str | Path, command: str = "", progress=print) -> dict[str, Any]:
    """``recurrent.members`` students (module docstring) in ``out_dir``; returns the train log."""
    from petswarm.evaluation.grid_spec import load_grid
    from petswarm_env.env import PetSwarmEnv

    members = cfg.recurrent.members
    if cfg.recurrent.target != "action":
        raise ConfigError("recurrent.members > 1 averages the students' actions; recurrent.target: estimate cannot be averaged "
                          "so (set recurrent.members: 1)")
    out = Path(out_dir)
    if (out / "train_log.json").exists():
        raise ConfigError(f"'{out}' already holds a run; choose another --out (a recurrent run is not resumable)")
    out.mkdir(parents=True, exist_ok=True)
    start = time.time()
    validated = cfg.recurrent.keep_members or cfg.recurrent.member_checkpoint == "validated"
    if validated:  # the validation grid read before hours of training, not after
        load_grid(cfg.recurrent.member_grid, None, seed=cfg.recurrent.member_seeds[0])
    one = {"members": 1, "keep_members": 0, "member_checkpoint": "best"}  # a member is one student: what it reads back
    jobs = [(cfg.model_copy(update={"seed": cfg.seed + m, "recurrent": cfg.recurrent.model_copy(update=one)}),
             out / f"member_{m}", command) for m in range(members)]
    done = {m: log for m, (member, folder, _) in enumerate(jobs) if (log := finished_member(member, folder)) is not None}
    todo = [job for m, job in enumerate(jobs) if m not in done]
    workers = min(max(cfg.num_cpus, 1), max(len(todo), 1))
    if progress:
        progress(f"{members} members (seeds {cfg.seed}-{cfg.seed + members - 1}) in {out}/member_*"
                 + (f", {workers} at a time" if todo else "")
                 + (f"; members {', '.join(map(str, sorted(done)))} already trained there: kept" if done else ""))
    if workers == 1:
        trained = [_run_member(job, progress) for job in todo]
    else:  # each member a process of its own (one thread, its own seed: the same weights as one after another)
        with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
            trained = list(pool.map(_train_member, todo))
    logs = [done[m] if m in done else trained.pop(0) for m in range(members)]
    layout = PetSwarmEnv(cfg.env_config()).layout
    log: dict[str, Any] = {"timesteps": sum(lg["timesteps"] for lg in logs), "wall_time_s": time.time() - start,
                           "evaluations": [], "scripted_eval_rmse_m": None, "command": command, "_start": start,
                           "members": [{"seed": cfg.seed + m, "folder": f"member_{m}", "timesteps": lg["timesteps"],
                                        "wall_time_s": lg["wall_time_s"], "best": lg.get("best")} for m, lg in enumerate(logs)],
                           "rounds": [r for lg in logs for r in lg["rounds"]], "members_kept": sorted(done)}
    info = {"algorithm": f"{ALGORITHM}, parameter sharing over slaves", "members": members, "timesteps": log["timesteps"],
            "train_config": cfg.model_dump(mode="json"), "command": command}
    best = [out / f"member_{m}" / "policy.npz" for m in range(members)]
    last = [out / f"member_{m}" / LAST_POLICY for m in range(members)]
    checkpoint, chosen = cfg.recurrent.member_checkpoint, list(range(members))
    students = last if checkpoint == "last" else best
    if validated:  # each member's student, and the members, of the lowest score on the validation grid; all beside
        options = [[best[m], last[m]] if checkpoint == "validated" else [students[m]] for m in range(members)]
        log["member_validation"] = score_members(cfg, options, progress)
        students = [options[m][r["student"]] for m, r in enumerate(log["member_validation"]["members"])]
        chosen = log["member_validation"]["chosen"]
        if len(chosen) < members:
            write_merged(students, out / ALL_MEMBERS_POLICY, layout, info)
        info = {**info, "members": len(chosen), "members_chosen": chosen,
                "students": [students[m].name for m in chosen]}
    write_merged([last[m] for m in chosen], out / LAST_POLICY, layout, info)
    if checkpoint == "last":  # the mean of the last students is the policy; the mean of the best beside it
        write_merged([best[m] for m in chosen], out / MEMBERS_BEST_POLICY, layout, info)
    best = [students[m] for m in chosen]
    scratch = out / ".mean_for_evaluation.npz"  # the mean the evaluation drives, written once
    write_merged(best, scratch, layout, info)
    scripted_reference(cfg, log)
    try:
        evaluate_and_keep(cfg, out, log, lambda spec: LearnedPolicy.load(scratch, spec), log["timesteps"],
                          lambda path, i: write_merged(best, path, layout, {**info, **i}), ALGORITHM)
    finally:
        scratch.unlink(missing_ok=True)
    log["wall_time_s"] = time.time() - start
    write_json_atomic(out / "train_log.json", public_log(log))
    if progress:
        ev = log["evaluations"][-1]
        progress(f"the mean of {len(chosen)} of {members} students: eval median {cfg.eval.metric} ratio {ev['median_ratio']:.2f} "
                 f"(not built {ev['not_built']}), {log['wall_time_s']:.0f} s")
    return public_log(log)

