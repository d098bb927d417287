"""Learned slave policies: a weights-only file format we control, and a numpy forward pass.

A saved policy is one ``.npz`` file (numpy's zip of arrays, read by
:func:`petswarm_env.files.read_npz`: numbers only, never a pickle, so loading never executes
code from the file; every field is checked and a malformed one refused by name) holding the actor network's layers and a JSON
metadata record: the format version, the environment name and observation version it was trained
on (a newer version than the environment's is refused, an older one loads with a
:class:`PolicyVersionWarning`), the observation layout (field names and sizes), the activation, and how it was trained.

Loading matches the saved layout against the environment's, field by field (seed 001's mapping
idea, SPEC §5): fields that match by name and size are wired through (in any order); a field the
policy needs that the environment lacks, or has with another size, is refused with a message that
names it. Extra environment fields the policy never saw are ignored.

A *residual* policy (metadata ``residual_of: scripted`` and ``residual_scale: s``) is a
learned correction on top of the scripted reference (residual policy learning): its action is
``clip(scripted(obs) + s · clip(mlp(obs), -1, 1), -1, 1)``, both parts reading the same
observation of the same robot (:class:`Residual`); with a zero last layer it is the scripted
reference, bit for bit. A file without ``residual_of`` is a plain MLP policy (every file written
before the field existed).

A *recurrent* policy (format version 2, metadata ``recurrent: {cell: gru, hidden_size: H,
encoder_layers: k}``) carries a memory of the robot's observation history: layers ``0..k-1`` encode
the observation (the activation after each), a GRU cell (Cho et al. 2014, in torch's gate layout
``r, z, n``: arrays ``gru_w_ih``, ``gru_w_hh``, ``gru_b_ih``, ``gru_b_hh``) updates the hidden state
``h`` from the encoding, and the remaining layers map ``[encoding, h]`` to the action. ``h`` is one
vector per robot, zero at the start of an episode and whenever a robot (re)joins slave-role driving
(:class:`RecurrentPolicy`): what the robot remembers is only what arrived in its own observations.

An *estimating* recurrent policy (metadata ``estimator: {outputs, scale, law}`` besides
``recurrent``) has a head of seven outputs, an estimate of what the privileged teacher reads, and
acts with the teacher's control law on that estimate (:mod:`petswarm.baselines.estimator`).
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from petswarm_env.mapping import MOVE_HOLONOMIC, Behaviour
from petswarm.baselines.leader_follower import LeaderFollowerPolicy
from petswarm.baselines.members import MemberStack
from petswarm.baselines.policy import Policy, PolicySpec
from petswarm_env.config import describe_value
from petswarm_env.env import ENV_NAME

# Policy files this env reads: its own and petswarm_v0's. v1 keeps v0's action and observation
# (fields are matched by name) but changed the swarm's dynamics, so a v0 policy loads with a warning.
COMPATIBLE_ENVS = ("petswarm_v0", ENV_NAME)
from petswarm_env.files import read_npz, write_atomic
from petswarm_env.observe import OBS_VERSION, ObservationLayout

FORMAT = "petswarm-policy"
FORMAT_VERSION = 1  # a feed-forward actor (layers only)
RECURRENT_FORMAT_VERSION = 2  # a recurrent actor (encoder layers, a GRU cell, head layers): a reader of version 1 refuses it
FORMAT_VERSIONS = (FORMAT_VERSION, RECURRENT_FORMAT_VERSION)
CELLS = ("gru",)
GRU_ARRAYS = ("gru_w_ih", "gru_w_hh", "gru_b_ih", "gru_b_hh")
ACTIVATIONS = {"tanh": np.tanh, "relu": lambda x: np.maximum(x, 0.0)}
RESIDUAL_BASES = {"scripted": LeaderFollowerPolicy}  # what a residual policy corrects (a policy of the observation alone)


def _is_scale(x: Any) -> bool:
    """A residual's bound: a number in (0, 1]."""
    return not isinstance(x, bool) and isinstance(x, (int, float)) and 0.0 < x <= 1.0


@dataclass(frozen=True)
class Residual:
    """A residual policy's base (``of``, a name of :data:`RESIDUAL_BASES`) and the bound of its
    correction (``scale``, in action units: 0 < scale <= 1): the action sent is
    ``clip(base + scale · clip(correction, -1, 1), -1, 1)``."""

    of: str
    scale: float = 1.0

    def __post_init__(self):
        if self.of not in RESIDUAL_BASES:
            raise ValueError(f"residual_of must be one of {sorted(RESIDUAL_BASES)}, got {self.of!r}")
        if not _is_scale(self.scale):
            raise ValueError(f"residual_scale must be a number in (0, 1], got {self.scale!r}")

    def base_policy(self, spec: PolicySpec) -> Policy:
        return RESIDUAL_BASES[self.of](spec)

    def apply(self, base_action: np.ndarray, correction: np.ndarray) -> np.ndarray:
        """The action sent: the base's plus the bounded correction, clipped (float32)."""
        c = np.clip(np.asarray(correction, dtype=np.float32), -1.0, 1.0)
        if self.scale != 1.0:
            c = c * np.float32(self.scale)
        return np.clip(base_action + c, -1.0, 1.0)

    def meta(self) -> dict[str, Any]:
        return {"residual_of": self.of, "residual_scale": float(self.scale)}


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * x))  # = 1 / (1 + exp(-x)), without overflow


@dataclass(frozen=True)
class GRUCell:
    """A GRU cell's weights in torch's ``nn.GRU`` layout (the gates ``r, z, n`` stacked by rows):
    ``w_ih`` (3H, in), ``w_hh`` (3H, H), ``b_ih`` and ``b_hh`` (3H,). :meth:`step` is torch's
    equations (Cho et al. 2014): ``r = σ(W_ir x + b_ir + W_hr h + b_hr)``, ``z`` likewise,
    ``n = tanh(W_in x + b_in + r ⊙ (W_hn h + b_hn))``, ``h' = (1 − z) ⊙ n + z ⊙ h``."""

    w_ih: np.ndarray
    w_hh: np.ndarray
    b_ih: np.ndarray
    b_hh: np.ndarray

    @property
    def hidden_size(self) -> int:
        return self.w_hh.shape[1]

    def arrays(self) -> dict[str, np.ndarray]:
        return dict(zip(GRU_ARRAYS, (self.w_ih, self.w_hh, self.b_ih, self.b_hh)))

    def step(self, x: np.ndarray, h: np.ndarray) -> np.ndarray:
        """The next hidden states (batch, H) from inputs ``x`` (batch, in) and states ``h`` (batch, H)."""
        n = self.hidden_size
        gi = x @ self.w_ih.T + self.b_ih
        gh = h @ self.w_hh.T + self.b_hh
        r = _sigmoid(gi[:, :n] + gh[:, :n])
        z = _sigmoid(gi[:, n:2 * n] + gh[:, n:2 * n])
        c = np.tanh(gi[:, 2 * n:] + r * gh[:, 2 * n:])
        return (1.0 - z) * c + z * h


@dataclass(frozen=True)
class Recurrent:
    """A recurrent actor's memory (module docstring): the first ``encoder_layers`` layers encode the
    observation, ``cell`` updates the hidden state from the encoding, the other layers read
    ``[encoding, hidden state]``."""

    encoder_layers: int
    cell: GRUCell

    def meta(self) -> dict[str, Any]:
        return {"recurrent": {"cell": "gru", "hidden_size": int(self.cell.hidden_size), "encoder_layers": int(self.encoder_layers)}}


class PolicyLoadError(ValueError):
    """A policy file is missing, corrupt, or does not fit the environment."""


class PolicyVersionWarning(UserWarning):
    """A policy trained on an older observation version is loaded (its fields matched by name)."""


def shipped_policy_path() -> Path:
    """The learned policy shipped with the package (``petswarm run/eval --policy learned``): the mean of
    eight recurrent students of the privileged teacher, one network (``petswarm train --config
    recurrent_eight_students``, training/ensemble.py, docs/training.md)."""
    return Path(str(resources.files("petswarm.baselines") / "models" / "recurrent_eight_students.npz"))


def feed_forward_policy_path() -> Path:
    """The shipped one-frame MLP policy (MAPPO after a DAgger warm start, ``configs/train/generalize.yaml``;
    ``learned`` before the recurrent one): for tools that need a feed-forward actor (the TorchRL example)."""
    return Path(str(resources.files("petswarm.baselines") / "models" / "mappo_generalize.npz"))


def save_policy(path: str | os.PathLike, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                layout: ObservationLayout, info: dict[str, Any] | None = None, behaviours: list[str] | None = None,
                residual: Residual | None = None, recurrent: Recurrent | None = None,
                estimator: dict[str, Any] | None = None) -> None:
    """Write ``layers`` ((weight (out, in), bias (out,)) each; the last one is linear) atomically.
    ``behaviours``: the behaviours the policy commands (seed 001 §IV; default MOVE, the env's action);
    ``residual``: the policy the layers correct and the correction's bound (module docstring; None:
    a plain MLP policy); ``recurrent``: the GRU between the encoder layers and the head layers
    (format version 2; None: a feed-forward policy, version 1); ``estimator``: a recurrent policy's
    estimate and law (:mod:`petswarm.baselines.estimator`; None: the layers give the action)."""
    if activation not in ACTIVATIONS:
        raise ValueError(f"activation must be one of {sorted(ACTIVATIONS)}, got '{activation}'")
    meta = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION if recurrent is None else RECURRENT_FORMAT_VERSION,
        "env_name": ENV_NAME,
        "observation_version": OBS_VERSION,
        "observation_layout": [[name, size] for name, size in layout.signature()],
        "activation": activation,
        "num_layers": len(layers),
        "info": info or {},
        "behaviours": list(behaviours or ["MOVE"]),
    }
    if residual is not None:
        meta.update(residual.meta())
    if recurrent is not None:
        meta.update(recurrent.meta())
    if estimator is not None:
        meta["estimator"] = estimator
    arrays = {"meta": np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)}
    for i, (w, b) in enumerate(layers):
        arrays[f"w{i}"] = np.asarray(w, dtype=np.float32)
        arrays[f"b{i}"] = np.asarray(b, dtype=np.float32)
    for name, a in (recurrent.cell.arrays().items() if recurrent is not None else ()):
        arrays[name] = np.asarray(a, dtype=np.float32)
    write_atomic(path, lambda tmp: np.savez_compressed(tmp, **arrays), suffix=".npz")  # a mean of students: zeros off its blocks


MAX_POLICY_BYTES = 256_000_000  # far above any slave MLP (the shipped one is 100 KB); refuses absurd declarations
MAX_LAYERS = 64
REQUIRED = ("env_name", "observation_version", "observation_layout", "activation", "num_layers")
FIX = "re-export the policy from its run or re-train it"


def _field_error(path: Path, field: str, problem: str) -> PolicyLoadError:
    return PolicyLoadError(f"policy file '{path}': field '{field}' {problem}; {FIX}")


def _is_int(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _read_meta(path: Path, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """The metadata record, every field checked (type, then value)."""
    if "meta" not in arrays:
        if "state" in arrays:
            raise PolicyLoadError(f"'{path}' is a training checkpoint, not a policy; use the run's policy.npz")
        raise PolicyLoadError(f"policy file '{path}' has no 'meta' record: it is not a petswarm policy file")
    raw = arrays["meta"]
    if raw.dtype != np.uint8 or raw.ndim != 1:
        raise _field_error(path, "meta", f"must be UTF-8 JSON bytes (a 1-D uint8 array), got {raw.dtype} of shape {raw.shape}")
    try:
        meta = json.loads(raw.tobytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise _field_error(path, "meta", f"is not UTF-8 JSON ({type(exc).__name__})") from None
    if not isinstance(meta, dict):
        raise _field_error(path, "meta", f"must be a JSON object, got {type(meta).__name__}")
    if meta.get("format") != FORMAT:
        if meta.get("format") == "petswarm-checkpoint":
            raise PolicyLoadError(f"'{path}' is a training checkpoint, not a policy; use the run's policy.npz")
        raise PolicyLoadError(f"'{path}' is not a petswarm policy file (field 'format' is {meta.get('format')!r}, "
                              f"a policy file has {FORMAT!r})")
    if meta.get("format_version") not in FORMAT_VERSIONS or not _is_int(meta.get("format_version")):
        raise PolicyLoadError(f"policy file '{path}': field 'format_version' is {meta.get('format_version')!r}, this "
                              f"petswarm reads versions {', '.join(map(str, FORMAT_VERSIONS))}; {FIX} with this petswarm")
    missing = [key for key in REQUIRED if key not in meta]
    if missing:
        raise _field_error(path, missing[0], "is missing")
    if meta.get("env_name") not in COMPATIBLE_ENVS:
        raise PolicyLoadError(f"policy file '{path}' was trained on env {meta.get('env_name')!r} (field 'env_name'), "
                              f"this is '{ENV_NAME}' (it reads {', '.join(COMPATIBLE_ENVS)})")
    version = meta.get("observation_version")
    if not _is_int(version) or version < 1:
        raise _field_error(path, "observation_version", f"must be a whole number >= 1, got {describe_value(version)}")
    if version > OBS_VERSION:
        raise PolicyLoadError(f"policy file '{path}': field 'observation_version' is {version}, newer than this environment's "
                              f"observation (version {OBS_VERSION}); use it with the petswarm it was trained with")
    layout = meta.get("observation_layout")
    if not isinstance(layout, list) or not layout:
        raise _field_error(path, "observation_layout",
                           f"must be a non-empty list of [name, size] pairs, got {describe_value(layout)}")
    for k, entry in enumerate(layout):
        pair = isinstance(entry, list) and len(entry) == 2
        if not (pair and isinstance(entry[0], str) and _is_int(entry[1]) and entry[1] >= 1):
            raise _field_error(path, "observation_layout", f"entry {k} must be [name, size >= 1], got {describe_value(entry)}")
    if len({name for name, _ in layout}) != len(layout):
        raise _field_error(path, "observation_layout", "names a field twice")
    if meta.get("activation") not in ACTIVATIONS:
        raise _field_error(path, "activation",
                           f"must be one of {sorted(ACTIVATIONS)}, got {describe_value(meta.get('activation'))}")
    n = meta.get("num_layers")
    if not _is_int(n) or not 1 <= n <= MAX_LAYERS:
        raise _field_error(path, "num_layers", f"must be a whole number from 1 to {MAX_LAYERS}, got {describe_value(n)}")
    if "residual_of" in meta and meta["residual_of"] not in RESIDUAL_BASES:
        raise _field_error(path, "residual_of", f"must be one of {sorted(RESIDUAL_BASES)} (the policy a residual policy "
                                                f"corrects), got {describe_value(meta['residual_of'])}")
    if not _is_scale(meta.get("residual_scale", 1.0)):
        raise _field_error(path, "residual_scale", f"must be a number in (0, 1] (the bound of a residual policy's "
                                                   f"correction), got {describe_value(meta['residual_scale'])}")
    if not isinstance(meta.get("info", {}), dict):
        raise _field_error(path, "info", f"must be a JSON object, got {type(meta['info']).__name__}")
    recurrent = meta.get("recurrent")
    if (meta["format_version"] == RECURRENT_FORMAT_VERSION) != (recurrent is not None):
        raise _field_error(path, "recurrent", f"must be given exactly when 'format_version' is {RECURRENT_FORMAT_VERSION} "
                                              f"(a recurrent policy), got {describe_value(recurrent)} with version {meta['format_version']}")
    if recurrent is not None:
        if not (isinstance(recurrent, dict) and recurrent.get("cell") in CELLS and _is_int(recurrent.get("hidden_size"))
                and recurrent["hidden_size"] >= 1 and _is_int(recurrent.get("encoder_layers"))
                and 0 <= recurrent["encoder_layers"] < n):
            raise _field_error(path, "recurrent", f"must be {{cell: one of {list(CELLS)}, hidden_size >= 1, encoder_layers from 0 "
                                                  f"to num_layers - 1}}, got {describe_value(recurrent)}")
    if "estimator" in meta:
        from petswarm.baselines.estimator import check_estimator_meta

        problem = "needs a recurrent policy (field 'recurrent')" if recurrent is None else check_estimator_meta(meta["estimator"])
        if problem is None and meta.get("residual_of") is not None:
            problem = "excludes 'residual_of' (an estimating policy's action comes from its law)"
        if problem:
            raise _field_error(path, "estimator", problem)
    return meta


def _read_layers(path: Path, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The layers (weight (out, in), bias (out,)): present, float, chained shapes, finite, the
    first taking the layout's values and the last giving the 3 action values."""
    layers = []
    rec = meta.get("recurrent")
    for i in range(meta["num_layers"]):
        for name in (f"w{i}", f"b{i}"):
            if name not in arrays:
                raise _field_error(path, name, f"is missing (field 'num_layers' says {meta['num_layers']} layers)")
            if arrays[name].dtype.kind != "f":
                raise _field_error(path, name, f"must hold floating-point weights, got {arrays[name].dtype}")
        w, b = arrays[f"w{i}"], arrays[f"b{i}"]
        before = layers[-1][0].shape[0] if i > 0 else None
        if rec is not None and i == rec["encoder_layers"]:  # the first head layer reads [encoding, hidden state]
            before = (before if i > 0 else w.shape[1] - rec["hidden_size"]) + rec["hidden_size"]
        if w.ndim != 2 or b.shape != (w.shape[0],) or (before is not None and w.shape[1] != before):
            raise _field_error(path, f"w{i}", f"has shape {w.shape} with bias {b.shape}, which does not chain with the "
                                              "layer before (weights (out, in), bias (out,)"
                                              + (", the first head layer reading [encoding, hidden state])" if rec else ")"))
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(b))):
            raise _field_error(path, f"w{i}", "or its bias holds NaN or infinite weights")
        layers.append((w, b))
    inputs = sum(size for _, size in meta["observation_layout"])
    if rec is not None and rec["encoder_layers"] == 0:  # the cell reads the observation, the head [observation, h]
        inputs += rec["hidden_size"]
    if layers[0][0].shape[1] != inputs:
        raise _field_error(path, "w0", f"takes {layers[0][0].shape[1]} inputs but field 'observation_layout' has {inputs} values")
    outputs = len(meta["estimator"]["outputs"]) if "estimator" in meta else 3
    if layers[-1][0].shape[0] != outputs:
        raise _field_error(path, f"w{len(layers) - 1}", f"outputs {layers[-1][0].shape[0]} values; "
                                                        + (f"the estimate has {outputs}" if "estimator" in meta else "a slave action has 3"))
    return layers


def _read_cell(path: Path, arrays: dict[str, np.ndarray], meta: dict[str, Any],
               layers: list[tuple[np.ndarray, np.ndarray]]) -> Recurrent | None:
    """A recurrent policy's GRU cell, its shapes chained between the encoder and the head."""
    rec = meta.get("recurrent")
    if rec is None:
        return None
    k, n = rec["encoder_layers"], rec["hidden_size"]
    feed = layers[k - 1][0].shape[0] if k > 0 else sum(size for _, size in meta["observation_layout"])
    shapes = {"gru_w_ih": (3 * n, feed), "gru_w_hh": (3 * n, n), "gru_b_ih": (3 * n,), "gru_b_hh": (3 * n,)}
    for name, shape in shapes.items():
        a = arrays.get(name)
        if a is None:
            raise _field_error(path, name, "is missing (field 'recurrent' declares a GRU cell)")
        if a.dtype.kind != "f" or a.shape != shape:
            raise _field_error(path, name, f"must be floating-point of shape {shape} (hidden_size {n}, input {feed}), "
                                           f"got {a.dtype} of shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise _field_error(path, name, "holds NaN or infinite weights")
    return Recurrent(k, GRUCell(*(arrays[name] for name in GRU_ARRAYS)))


def read_policy(path: str | os.PathLike) -> tuple[dict[str, Any], list[tuple[np.ndarray, np.ndarray]], Recurrent | None]:
    """Metadata, layers and (a recurrent policy's) :class:`Recurrent` of a policy file (:func:`read_policy_file`)."""
    path = Path(path)
    arrays = _read_arrays(path)
    meta = _read_meta(path, arrays)
    layers = _read_layers(path, arrays, meta)
    return meta, layers, _read_cell(path, arrays, meta, layers)


def read_policy_file(path: str | os.PathLike) -> tuple[dict[str, Any], list[tuple[np.ndarray, np.ndarray]]]:
    """Metadata and layers of a policy file (of a recurrent one: the encoder's and the head's,
    :func:`read_policy` gives its cell too); :class:`PolicyLoadError` names the file and the field
    of any problem. Never unpickles (:func:`petswarm_env.files.read_npz`)."""
    meta, layers, _ = read_policy(path)
    return meta, layers


def _read_arrays(path: Path) -> dict[str, np.ndarray]:
    if not path.is_file():
        raise PolicyLoadError(f"policy file '{path}' does not exist" + (" (it is a folder)" if path.is_dir() else ""))
    try:
        arrays = read_npz(path, MAX_POLICY_BYTES)
    except ValueError as exc:
        raise PolicyLoadError(f"policy file '{path}' cannot be read: {exc}; {FIX}") from None
    except OSError as exc:
        raise PolicyLoadError(f"policy file '{path}' cannot be read ({exc.strerror or exc})") from None
    return arrays


def observation_mapping(saved: list[tuple[str, int]], layout: ObservationLayout) -> np.ndarray:
    """Indices into the env's observation that rebuild the saved layout, or PolicyLoadError."""
    have = dict(layout.signature())
    problems = []
    for name, size in saved:
        if name not in have:
            problems.append(f"field '{name}' (size {size}) is missing from this environment's observation")
        elif have[name] != size:
            problems.append(f"field '{name}' has size {have[name]} here but the policy was trained with size {size}")
    if problems:
        raise PolicyLoadError("observation layout differs from the one the policy was trained on: " + "; ".join(problems))
    idx = []
    for name, _size in saved:
        s = layout.slices[name]
        idx.extend(range(s.start, s.stop))
    return np.array(idx, dtype=np.intp)


def residual_of_meta(meta: dict[str, Any]) -> Residual | None:
    """The :class:`Residual` a policy's metadata declares (None for a plain MLP policy; a file's
    fields are checked by :func:`read_policy_file`, a bad one given in code raises ValueError)."""
    return Residual(meta["residual_of"], meta.get("residual_scale", 1.0)) if meta.get("residual_of") is not None else None


class LearnedPolicy(Policy):
    """A saved MLP actor evaluated with numpy (deterministic: the mean action, clipped); with
    ``meta["residual_of"]`` that action, times ``meta["residual_scale"]``, corrects the named base
    policy's (module docstring, :class:`Residual`)."""

    name = "learned"

    def __init__(self, spec: PolicySpec, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                 index: np.ndarray, meta: dict[str, Any] | None = None):
        # the behaviours its file declares (optional "behaviours": names; default MOVE, the action it was trained on)
        names = (meta or {}).get("behaviours", ["MOVE"])
        if not isinstance(names, list) or not all(isinstance(n, str) and n for n in names):
            raise PolicyLoadError(f"policy field 'behaviours' must be a list of behaviour names such as ['MOVE'], got {describe_value(names)}")
        self.behaviours = tuple(MOVE_HOLONOMIC if n == "MOVE" else Behaviour(str(n)) for n in names)
        super().__init__(spec)
        self.layers = [(w.astype(np.float64), b.astype(np.float64)) for w, b in layers]
        self.act_fn = ACTIVATIONS[activation]
        self.index = index
        self.meta = meta or {}
        identity = len(index) == spec.layout.size and np.array_equal(index, np.arange(spec.layout.size))
        self._identity = identity
        self.residual = residual_of_meta(self.meta)
        self.base = self.residual.base_policy(spec) if self.residual else None  # reads the env's observation, as the MLP does

    @classmethod
    def load(cls, path: str | os.PathLike, spec: PolicySpec) -> LearnedPolicy:
        """The policy of a file: a :class:`LearnedPolicy`, or a :class:`RecurrentPolicy` for a recurrent file."""
        meta, layers, recurrent = read_policy(path)
        if meta["env_name"] != ENV_NAME:
            warnings.warn(f"policy file '{path}' was trained on {meta['env_name']}, this environment is {ENV_NAME} (the same "
                          "observation and action, other swarm dynamics); its results are not comparable to a "
                          f"{ENV_NAME} policy's until it is re-trained", PolicyVersionWarning, stacklevel=2)
        if meta["observation_version"] < OBS_VERSION:
            warnings.warn(f"policy file '{path}' was trained on observation version {meta['observation_version']}, this "
                          f"environment's is {OBS_VERSION}: its fields are matched by name and size, but one may mean "
                          "something else now (docs/observation.md); re-train it to be sure", PolicyVersionWarning, stacklevel=2)
        saved = [(n, s) for n, s in meta["observation_layout"]]
        try:
            index = observation_mapping(saved, spec.layout)
        except PolicyLoadError as exc:
            raise PolicyLoadError(f"policy file '{path}': {exc}") from None
        if "estimator" in meta:
            from petswarm.baselines.estimator import EstimatorPolicy

            return EstimatorPolicy(spec, layers, meta["activation"], index, recurrent, meta)
        if recurrent is not None:
            return RecurrentPolicy(spec, layers, meta["activation"], index, recurrent, meta)  # residual too if the file says so
        return cls(spec, layers, meta["activation"], index, meta)

    def forward(self, obs: np.ndarray) -> np.ndarray:
        x = np.asarray(obs, dtype=np.float64)
        x = x if self._identity else x[..., self.index]
        for w, b in self.layers[:-1]:
            x = self.act_fn(x @ w.T + b)
        w, b = self.layers[-1]
        return x @ w.T + b

    def act(self, agent: str, observation: np.ndarray) -> np.ndarray:
        out = np.clip(self.forward(observation), -1.0, 1.0).astype(np.float32)
        return out if self.base is None else self.residual.apply(self.base.act(agent, observation), out)

    def act_all(self, observations: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        if not observations:
            return {}
        agents = list(observations)
        out = np.clip(self.forward(np.stack([observations[a] for a in agents])), -1.0, 1.0).astype(np.float32)
        if self.base is None:
            return {a: out[i] for i, a in enumerate(agents)}
        return {a: self.residual.apply(self.base.act(a, observations[a]), out[i]) for i, a in enumerate(agents)}


class RecurrentPolicy(LearnedPolicy):
    """A saved recurrent actor (module docstring: encoder, GRU cell, head) evaluated with numpy: the
    mean action, clipped (with ``residual_of``: the correction of the base policy's action, as
    :class:`Residual`). It keeps one hidden state per agent: zero at :meth:`reset` (the start of
    an episode) and for an agent that did not act on the step before (it just joined, or rejoined,
    slave-role driving); a waiting agent's zero observation (the env's padding, never a real one: a
    real observation's yaw sin/cos lie on the unit circle) does not count as acting, so a loop that
    passes every agent of ``env.agents`` starts a returning robot's memory again too. A step is one :meth:`act_all` call, or a round of :meth:`act` calls in
    which no agent is asked twice."""

    def __init__(self, spec: PolicySpec, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                 index: np.ndarray, recurrent: Recurrent, meta: dict[str, Any] | None = None):
        super().__init__(spec, layers, activation, index, {**(meta or {}), **recurrent.meta()})
        self.encoder_layers = recurrent.encoder_layers
        c = recurrent.cell
        self.cell = GRUCell(*(np.asarray(a, dtype=np.float64) for a in (c.w_ih, c.w_hh, c.b_ih, c.b_hh)))
        members = (meta or {}).get("info", {}).get("members", 1)  # a mean of students (training/ensemble.py)
        self._stack = MemberStack.split(self.layers, self.encoder_layers, self.cell, members if isinstance(members, int) else 1)
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self._hidden: dict[str, np.ndarray] = {}
        self._last: dict[str, int] = {}  # the step on which each agent last acted
        self._step = 0
        self._asked: set[str] = set()

    def hidden(self, agent: str) -> np.ndarray | None:
        """The agent's hidden state after its last action (None before its first)."""
        return self._hidden.get(agent)

    def step_batch(self, x: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One step of the network for a batch: observations ``x`` (batch, env observation) and
        hidden states ``h`` (batch, H) -> (mean actions, unclipped (batch, 3); next hidden states)."""
        x = np.asarray(x, dtype=np.float64)
        x = x if self._identity else x[..., self.index]
        return self._stack.step(x, np.asarray(h, dtype=np.float64), self.act_fn)  # each member on its own (baselines/members.py)

    def forward(self, obs: np.ndarray) -> np.ndarray:
        raise TypeError("a recurrent policy has no one-frame forward pass; use act_all (or step_batch with hidden states)")

    def act(self, agent: str, observation: np.ndarray) -> np.ndarray:
        if agent in self._asked:  # asked twice: a new step
            self._step += 1
            self._asked = set()
        return self._act([agent], [observation])[agent]

    def act_all(self, observations: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        self._step += 1
        self._asked = set()
        return self._act(list(observations), [observations[a] for a in observations]) if observations else {}

    def _act(self, agents: list[str], observations: list[np.ndarray]) -> dict[str, np.ndarray]:
        n = self.cell.hidden_size
        zero = np.zeros(n)
        h = np.stack([self._hidden[a] if self._last.get(a) == self._step - 1 else zero for a in agents])
        out, h = self.step_batch(np.stack(observations), h)
        out = np.clip(out, -1.0, 1.0).astype(np.float32)
        padding = ~np.asarray(observations).any(axis=1)  # a waiting agent's zeros
        for i, a in enumerate(agents):
            if padding[i]:
                self._last.pop(a, None)
                self._hidden.pop(a, None)
            else:
                self._hidden[a], self._last[a] = h[i], self._step
            self._asked.add(a)
        if self.base is not None:  # a residual recurrent policy: the memory corrects the base policy's action
            return {a: self.residual.apply(self.base.act(a, observations[i]), out[i]) for i, a in enumerate(agents)}
        return {a: out[i] for i, a in enumerate(agents)}
