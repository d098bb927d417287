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
from petswarm.baselines.policy import Policy, PolicySpec
from petswarm_env.config import describe_value
from petswarm_env.env import ENV_NAME

# Policy files this env reads: its own and petswarm_v0's. v1 keeps v0's action and observation
# (fields are matched by name) but changed the swarm's dynamics, so a v0 policy loads with a warning.
COMPATIBLE_ENVS = ("petswarm_v0", ENV_NAME)
from petswarm_env.files import read_npz, write_atomic
from petswarm_env.observe import OBS_VERSION, ObservationLayout

FORMAT = "petswarm-policy"
FORMAT_VERSION = 1
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


class PolicyLoadError(ValueError):
    """A policy file is missing, corrupt, or does not fit the environment."""


class PolicyVersionWarning(UserWarning):
    """A policy trained on an older observation version is loaded (its fields matched by name)."""


def shipped_policy_path() -> Path:
    """The learned policy shipped with the package (``petswarm run/eval --policy learned``)."""
    return Path(str(resources.files("petswarm.baselines") / "models" / "mappo_generalize.npz"))


def save_policy(path: str | os.PathLike, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                layout: ObservationLayout, info: dict[str, Any] | None = None, behaviours: list[str] | None = None,
                residual: Residual | None = None) -> None:
    """Write ``layers`` ((weight (out, in), bias (out,)) each; the last one is linear) atomically.
    ``behaviours``: the behaviours the policy commands (seed 001 §IV; default MOVE, the env's action);
    ``residual``: the policy the layers correct and the correction's bound (module docstring; None:
    a plain MLP policy)."""
    if activation not in ACTIVATIONS:
        raise ValueError(f"activation must be one of {sorted(ACTIVATIONS)}, got '{activation}'")
    meta = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
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
    arrays = {"meta": np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)}
    for i, (w, b) in enumerate(layers):
        arrays[f"w{i}"] = np.asarray(w, dtype=np.float32)
        arrays[f"b{i}"] = np.asarray(b, dtype=np.float32)
    write_atomic(path, lambda tmp: np.savez(tmp, **arrays), suffix=".npz")


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
    if meta.get("format_version") != FORMAT_VERSION or not _is_int(meta.get("format_version")):
        raise PolicyLoadError(f"policy file '{path}': field 'format_version' is {meta.get('format_version')!r}, this "
                              f"petswarm reads version {FORMAT_VERSION}; {FIX} with this petswarm")
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
    return meta


def _read_layers(path: Path, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The layers (weight (out, in), bias (out,)): present, float, chained shapes, finite, the
    first taking the layout's values and the last giving the 3 action values."""
    layers = []
    for i in range(meta["num_layers"]):
        for name in (f"w{i}", f"b{i}"):
            if name not in arrays:
                raise _field_error(path, name, f"is missing (field 'num_layers' says {meta['num_layers']} layers)")
            if arrays[name].dtype.kind != "f":
                raise _field_error(path, name, f"must hold floating-point weights, got {arrays[name].dtype}")
        w, b = arrays[f"w{i}"], arrays[f"b{i}"]
        if w.ndim != 2 or b.shape != (w.shape[0],) or (i > 0 and w.shape[1] != layers[-1][0].shape[0]):
            raise _field_error(path, f"w{i}", f"has shape {w.shape} with bias {b.shape}, which does not chain with the "
                                              "layer before (weights (out, in), bias (out,))")
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(b))):
            raise _field_error(path, f"w{i}", "or its bias holds NaN or infinite weights")
        layers.append((w, b))
    inputs = sum(size for _, size in meta["observation_layout"])
    if layers[0][0].shape[1] != inputs:
        raise _field_error(path, "w0", f"takes {layers[0][0].shape[1]} inputs but field 'observation_layout' has {inputs} values")
    if layers[-1][0].shape[0] != 3:
        raise _field_error(path, f"w{len(layers) - 1}", f"outputs {layers[-1][0].shape[0]} values; a slave action has 3")
    return layers


def read_policy_file(path: str | os.PathLike) -> tuple[dict[str, Any], list[tuple[np.ndarray, np.ndarray]]]:
    """Metadata and layers of a policy file; :class:`PolicyLoadError` names the file and the
    field of any problem. Never unpickles (:func:`petswarm_env.files.read_npz`)."""
    path = Path(path)
    if not path.is_file():
        raise PolicyLoadError(f"policy file '{path}' does not exist" + (" (it is a folder)" if path.is_dir() else ""))
    try:
        arrays = read_npz(path, MAX_POLICY_BYTES)
    except ValueError as exc:
        raise PolicyLoadError(f"policy file '{path}' cannot be read: {exc}; {FIX}") from None
    except OSError as exc:
        raise PolicyLoadError(f"policy file '{path}' cannot be read ({exc.strerror or exc})") from None
    meta = _read_meta(path, arrays)
    return meta, _read_layers(path, arrays, meta)


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
        meta, layers = read_policy_file(path)
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
