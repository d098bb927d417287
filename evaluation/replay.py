"""Episode replays: a compact per-step trace of what the experimenter sees, for the report's viewer.

    petswarm eval --policy scripted --replay-dir replays/ --json scripted.json
    petswarm report scripted.json learned.json --out report.html     # embeds the viewer

:class:`ReplayRecorder` is called like :class:`petswarm.evaluation.runner.VideoRecorder` — after the reset
and after every step — and reads the experimenter's view only: the world's truth (bodies), the
experimenter's reference points, formation links and errors (:mod:`petswarm_env.metrics`), the
middleware's states, the IR token holders, the arbiters' winners and the radio medium's trace
(:attr:`petswarm_env.comms.radio.RadioMedium.trace`). No policy ever sees it.

**The file** (``<label>_<scenario>_seed<S>.replay.json``, one per episode; compact JSON, no NaN):
``format`` = ``"petswarm-replay"``, ``version`` = 1, ``label``, ``scenario``, ``seed``, ``dt_s``
(one step), ``t0_s`` (the clock at the end of reset), ``frames`` (F: frame 0 is the state after reset,
frame k the state after step k), ``units`` (positions and radii in mm, angles in mrad, errors in mm:
quantised integers), ``arena`` (``walls`` as ``[x1, y1, x2, y2]``, ``boxes`` as ``[cx, cy, w, h]``),
``robot_radius``, ``user_radius``, and

* ``users``: per user ``x``, ``y``, ``th`` (F values each, delta-coded: see below), and the runs ``activity`` (what the user
  does: stop/rest/walk/run), ``state`` (the user's robot state, seed 002 Fig. 4), ``master`` (the
  robot index of the master), and ``commands`` (``[frame, command]`` for every command the user's
  robot received, the start-up ones at frame 0);
* ``robots``: per robot ``id``, ``type`` (``petbot`` for every robot: the
  replay does not record a mixed pool's types yet), ``x``, ``y``, ``th``, ``ref_x``, ``ref_y`` (its reference point, null
  while it has none), and the runs ``role`` (master/slave/waiting/other), ``state`` (its middleware's
  sequence state: waiting, organizing, master, slave, …), ``member`` (member number, -1 outside a
  swarm), ``arbiter`` (the source that won its arbiter on that step: safety/user/policy, "" when
  its arbiter did not decide);
* ``links``: a run of the formation links as ``[neighbour, member]`` robot-index pairs;
  ``holder``: a run of the IR token holders (robot indices, one per swarm: the robot holding the
  newest token — the previous holder still waits for its token's acknowledgement);
* ``error``: the mean formation error of the step (the env's ``metrics.error_trace``; null on a
  step without one);
* ``radio``: ``kinds`` (frame types in order of first appearance) and per outcome ``sent``, ``lost``,
  ``collided`` a list per kind of F counts: bin 0 is the reset (pairing, organize), bin k the
  events during step k. Summed over bins 1… they are the episode summary's ``frames``.

A *run* is a list of ``[frame, value]`` changes: the value holds from that frame until the next
change. The per-frame series ``x``, ``y``, ``th``, ``ref_x``, ``ref_y`` and ``error`` are
*delta-coded*: each entry is the value minus the previous non-null value (the first minus 0), null
stays null (:func:`undelta` decodes them); this halves the gzipped size the report embeds.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from petswarm.evaluation.pcap import attach_trace, detach_trace
from petswarm_env.files import write_text_atomic

FORMAT, VERSION = "petswarm-replay", 1
ROBOT_TYPE = "petbot"  # every robot's type in a replay: the replay does not record a mixed pool's types yet
OUTCOMES = ("sent", "lost", "collided")


def replay_name(label: str, scenario: str, seed: int) -> str:
    """The file name of one episode's replay (the label made safe for a file name)."""
    return f"{re.sub(r'[^A-Za-z0-9_.-]+', '-', label)}_{scenario}_seed{seed}.replay.json"


DELTA_CODED = ("x", "y", "th", "ref_x", "ref_y")  # and "error"


def delta(values: list[int | None]) -> list[int | None]:
    """Delta coding: each value minus the previous non-null one (the first one minus 0); nulls stay."""
    out, prev = [], 0
    for v in values:
        if v is None:
            out.append(None)
        else:
            out.append(v - prev)
            prev = v
    return out


def undelta(values: list[int | None]) -> list[int | None]:
    """The inverse of :func:`delta`."""
    out, acc = [], 0
    for v in values:
        if v is None:
            out.append(None)
        else:
            acc += v
            out.append(acc)
    return out


def _mm(v: float) -> int:
    return int(round(v * 1000.0))


class _Run:
    """A run of values: ``[frame, value]`` on every change."""

    __slots__ = ("items", "last")

    def __init__(self) -> None:
        self.items: list[list] = []
        self.last: Any = object()

    def add(self, frame: int, value: Any) -> None:
        if value != self.last:
            self.items.append([frame, value])
            self.last = value


class ReplayRecorder:
    """Records one episode of ``env`` (from its next reset on) and writes the replay file (:meth:`close`)."""

    def __init__(self, env, path: str | Path, label: str, seed: int):
        self.env, self.path, self.label, self.seed = env, Path(path), label, seed
        attach_trace(env, self)
        self.frame = 0  # frames recorded so far = the radio bin of what happens now
        self.kinds: dict[str, list[list[int]]] = {}  # kind -> [sent, lost, collided] per bin

    # -- the radio trace (counts per frame type and bin) ------------------------------------------
    def _count(self, kind: str, outcome: int) -> None:
        counts = self.kinds.get(kind)
        if counts is None:
            counts = self.kinds[kind] = [[], [], []]
        row = counts[outcome]
        if len(row) <= self.frame:
            row.extend([0] * (self.frame + 1 - len(row)))
        row[self.frame] += 1

    def on_air(self, now, station, frame, start_s, end_s) -> None:
        self._count(frame.kind, 0)

    def reception(self, now, frame, receiver, outcome, distance_est_m) -> None:
        if outcome == "lost":
            self._count(frame.kind, 1)
        elif outcome == "collided":
            self._count(frame.kind, 2)

    def busy(self, now, station, frame) -> None:
        pass

    # -- one frame per step -----------------------------------------------------------------------
    def _start(self) -> None:
        env = self.env
        n_robots, n_users = len(env.truth.robots), len(env.truth.users)
        self.t0_s = env.truth.now
        self.robots = [{"x": [], "y": [], "th": [], "ref_x": [], "ref_y": [], **{k: _Run() for k in
                        ("role", "state", "member", "arbiter")}} for _ in range(n_robots)]
        self.users = [{"x": [], "y": [], "th": [], "commands": [], **{k: _Run() for k in ("activity", "state", "master")}}
                      for _ in range(n_users)]
        self.links, self.holder = _Run(), _Run()
        self.error: list[int | None] = []
        self._wins = {i: dict(a.counts.wins) for i, a in env.truth.arbiters.items()}
        self._commands_seen = [0] * n_users
        self._errors_seen = len(env.truth.error_trace)

    def __call__(self) -> None:
        """Record the current frame (after the reset, then after every step)."""
        if self.frame == 0:
            self._start()
        env, f = self.env, self.frame
        exp = env.truth
        centers, _, headings = env.truth.truth_arrays()
        xy, th = centers.tolist(), headings.tolist()
        refs = exp.reference_points(xy, th)
        for i, (rec, role) in enumerate(zip(self.robots, exp.roles())):
            rec["x"].append(_mm(xy[i][0]))
            rec["y"].append(_mm(xy[i][1]))
            rec["th"].append(_mm(th[i]))
            ref = refs.get(i)
            rec["ref_x"].append(None if ref is None else _mm(ref[0]))
            rec["ref_y"].append(None if ref is None else _mm(ref[1]))
            node = env.truth.nodes.get(i)
            rec["role"].add(f, role)
            rec["state"].add(f, node.state if node is not None else "none")
            rec["member"].add(f, node.know.member if node is not None else -1)
            rec["arbiter"].add(f, self._winner(i))
        n = len(self.robots)
        for u, (rec, session) in enumerate(zip(self.users, env.truth.sessions)):
            user = env.truth.users[u]
            rec["x"].append(_mm(xy[n + u][0]))
            rec["y"].append(_mm(xy[n + u][1]))
            rec["th"].append(_mm(user.heading))
            rec["activity"].add(f, user.activity)
            rec["state"].add(f, session.state)
            rec["master"].add(f, session.swarm.master.node_id)
            new = session.commands_received[self._commands_seen[u]:]
            rec["commands"] += [[f, cmd] for _, cmd in new]
            self._commands_seen[u] += len(new)
        self.links.add(f, [list(p) for p in exp.link_pairs()])
        self.holder.add(f, self._holders())
        trace = env.truth.error_trace
        self.error.append(_mm(trace[-1]) if f > 0 and len(trace) > self._errors_seen else None)
        self._errors_seen = len(trace)
        self.frame += 1

    def _holders(self) -> list[int]:
        """The IR token holder of each swarm: of the robots holding a slot, the one with the newest token
        (the previous holder still waits for the acknowledgement of the token it passed on)."""
        best: dict[int | None, Any] = {}
        for i, node in self.env.truth.nodes.items():
            ring = node.ring
            if ring.holding and (node.swarm_pan not in best or ring.token_seq > best[node.swarm_pan][0]):
                best[node.swarm_pan] = (ring.token_seq, i)
        return sorted(i for _, i in best.values())

    def _winner(self, robot: int) -> str:
        """The source that won robot ``robot``'s arbiter since the last frame ("" if it did not decide)."""
        arb = self.env.truth.arbiters.get(robot)
        if arb is None:
            return ""
        before, now = self._wins[robot], arb.counts.wins
        won = next((s for s in now if now[s] > before.get(s, 0)), "")
        self._wins[robot] = dict(now)
        return won

    # -- the file -----------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        env, frames = self.env, self.frame
        cfg = env.cfg
        walls = env.truth.wall_segments[:4] if cfg.world.arena_m[0] > 0 else []
        kinds = list(self.kinds)

        def full(row: list[int]) -> list[int]:
            return row + [0] * (frames - len(row))

        def runs(rec: dict) -> dict:
            return {k: (v.items if isinstance(v, _Run) else delta(v) if k in DELTA_CODED else v) for k, v in rec.items()}

        return {
            "format": FORMAT, "version": VERSION, "label": self.label, "scenario": env.scenario, "seed": self.seed,
            "dt_s": cfg.control_period_s, "t0_s": self.t0_s, "frames": frames,
            "units": {"position": "mm", "angle": "mrad", "error": "mm"},
            "arena": {"walls": [[_mm(a[0]), _mm(a[1]), _mm(b[0]), _mm(b[1])] for a, b in walls],
                      "boxes": [[_mm(v) for v in (*b.center_m, *b.size_m)] for b in cfg.world.obstacles]},
            "robot_radius": _mm(cfg.robot.radius_m), "user_radius": _mm(cfg.user.radius_m),
            "users": [runs(u) for u in self.users],
            "robots": [{"id": i, "type": ROBOT_TYPE, **runs(r)} for i, r in enumerate(self.robots)],
            "links": self.links.items, "holder": self.holder.items, "error": delta(self.error),
            "radio": {"kinds": kinds, **{o: [full(self.kinds[k][j]) for k in kinds] for j, o in enumerate(OUTCOMES)}},
        }

    def close(self) -> str:
        """Stop recording and write the replay file (atomically); returns its path."""
        detach_trace(self.env, self)
        write_text_atomic(self.path, json.dumps(self.to_dict(), separators=(",", ":"), allow_nan=False))
        return str(self.path)


def load_replay(path: str | Path) -> dict[str, Any]:
    """Read one replay file; a missing, unreadable or foreign file is a ``ValueError`` naming it."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"{path}: replay file not found") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"{path}: not a replay file ({e})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError(f"{path}: not a replay file (no \"format\": \"{FORMAT}\")")
    if data.get("version") != VERSION:
        raise ValueError(f"{path}: replay version {data.get('version')}, this petswarm reads version {VERSION}")
    return data
