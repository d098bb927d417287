"""The three ``swarm.assignment`` strategies side by side: seed 000 Table 2's
``closest``, seed 003 Algorithm 1 (``ruta_centralized``) and Algorithm 2 (``ruta_decentralized``).

Usage:
    python -m petswarm.experiments.assignment_compare [--seeds N] [--seed S] [--steps S] [--loss P]
                                             [--set KEY=VALUE ...] [--json OUT]

For each strategy, ``--seeds`` episodes of the default scenario (seeds ``seed, seed+1, …``) with the
scripted reference: the organize time (``organize_summary``), the radio frames the organize put on
the air (every transmission of the join protocol's frames, RUTA's status queries and answers, slot
announcements and bids included, counted by the medium's trace hook), the join retries, the slaves
missing, and the formation RMSE of the episode (``episode_summary``, ``--steps`` steps). The same
seed places the same robots in every strategy; only the assignment differs. Not a paper figure:
seed 003 has no formation, and its robots and radio are not ours.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.cli.errors import OneLineParser, run_program
from petswarm_env.config import ASSIGNMENTS, parse_override
from petswarm_env.files import write_json_atomic
from petswarm_env.middleware import messages as msg

ORGANIZE_KINDS = frozenset({msg.SCAN, msg.SCAN_RESPONSE, msg.JOIN_QUERY, msg.JOIN_ANSWER, msg.STATUS_QUERY,
                            msg.STATUS_ANSWER, msg.SLOT_ANNOUNCE, msg.BID, msg.JOIN_NOTIFY, msg.NON_PARTICIPATE,
                            msg.NOTIFY_ACK})


class _Count:
    """A radio trace (``env.radio_trace``) counting the transmissions of the organize's frames."""

    def __init__(self) -> None:
        self.frames = 0
        self.bytes = 0

    def on_air(self, now, station, frame, start_s, end_s) -> None:
        if frame.kind in ORGANIZE_KINDS:
            self.frames += 1
            self.bytes += frame.size_bytes

    def reception(self, now, frame, receiver, outcome, distance_est_m) -> None:
        pass

    def busy(self, now, station, frame) -> None:
        pass


def episode(strategy: str, seed: int, steps: int, overrides: dict[str, Any]) -> dict[str, Any]:
    env = petswarm_env.parallel_env(max_cycles=steps, **{**overrides, "swarm.assignment": strategy})
    count = _Count()
    env.radio_trace = count
    policy = make_policy("scripted", PolicySpec.from_env(env), seed)
    obs, _ = env.reset(seed=seed)
    policy.reset(seed)
    (org,) = env.organize_summary()
    row = {"strategy": strategy, "seed": seed, "organize_time_s": org["organize_time_s"],
           "organize_frames": count.frames, "organize_bytes": count.bytes, "join_retries": org["join_retries"],
           "slaves_missing": org["slaves_missing"], "members": org["members"]}
    while env.agents:
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
    row["formation_rmse_m"] = env.episode_summary()["formation_rmse_m"]
    return row


def summarize(rows: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    out = {}
    for strategy in ASSIGNMENTS:
        rs = [r for r in rows if r["strategy"] == strategy]
        if rs:
            out[strategy] = {k: float(np.mean([r[k] for r in rs])) for k in
                             ("organize_time_s", "organize_frames", "organize_bytes", "join_retries", "slaves_missing",
                              "formation_rmse_m")}
            out[strategy]["n"] = len(rs)
    return out


def table(summary: dict[str, dict[str, float]]) -> str:
    lines = ["| assignment | organize time (s) | organize frames | bytes | join retries | slaves missing | formation RMSE (m) |",
             "|---|---|---|---|---|---|---|"]
    for s, v in summary.items():
        lines.append(f"| {s} | {v['organize_time_s']:.3f} | {v['organize_frames']:.1f} | {v['organize_bytes']:.0f} | "
                     f"{v['join_retries']:.1f} | {v['slaves_missing']:.1f} | {v['formation_rmse_m']:.3f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = OneLineParser(prog="python -m petswarm.experiments.assignment_compare", description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--loss", type=float, default=0.0, help="radio.loss_prob")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--json", metavar="OUT")
    args = ap.parse_args(argv)
    overrides = dict(parse_override(s) for s in args.set)
    overrides["radio.loss_prob"] = args.loss
    rows = [episode(s, args.seed + i, args.steps, overrides) for s in ASSIGNMENTS for i in range(args.seeds)]
    for r in rows:
        print(f"{r['strategy']:<19} seed {r['seed']}: organize {r['organize_time_s']:.3f} s, {r['organize_frames']} frames, "
              f"retries {r['join_retries']}, missing {r['slaves_missing']}, RMSE {r['formation_rmse_m']:.3f} m, "
              f"members {r['members']}")
    summary = summarize(rows)
    print()
    print(table(summary))
    if args.json:
        write_json_atomic(args.json, {"args": vars(args), "rows": rows, "summary": summary,
                                      "finite": all(math.isfinite(r["formation_rmse_m"]) for r in rows)})
    return 0


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.assignment_compare", main))
