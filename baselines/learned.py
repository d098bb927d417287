"""Learned slave policies: a weights-only file format we control, and a numpy forward pass.

A saved policy is one ``.npz`` file (numpy's zip of arrays, read with ``allow_pickle=False``, so
loading never executes code from the file) holding the actor network's layers and a JSON
metadata record: the format version, the environment name and observation version it was trained
on, the observation layout (field names and sizes), the activation, and how it was trained.

Loading matches the saved layout against the environment's, field by field (seed 001's mapping
idea, SPEC §5): fields that match by name and size are wired through (in any order); a field the
policy needs that the environment lacks, or has with another size, is refused with a message that
names it. Extra environment fields the policy never saw are ignored.
"""

from __future__ import annotations

import json
import os
import zipfile
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from baselines.policy import Policy, PolicySpec
from petswarm_env.env import ENV_NAME
from petswarm_env.files import write_atomic
from petswarm_env.observe import OBS_VERSION, ObservationLayout

FORMAT = "petswarm-policy"
FORMAT_VERSION = 1
ACTIVATIONS = {"tanh": np.tanh, "relu": lambda x: np.maximum(x, 0.0)}


class PolicyLoadError(ValueError):
    """A policy file is missing, corrupt, or does not fit the environment."""


def shipped_policy_path() -> Path:
    """The learned policy shipped with the package (``petswarm run/eval --policy learned``)."""
    return Path(str(resources.files("baselines") / "models" / "ppo_wedge.npz"))


def save_policy(path: str | os.PathLike, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                layout: ObservationLayout, info: dict[str, Any] | None = None) -> None:
    """Write ``layers`` ((weight (out, in), bias (out,)) each; the last one is linear) atomically."""
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
    }
    arrays = {"meta": np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)}
    for i, (w, b) in enumerate(layers):
        arrays[f"w{i}"] = np.asarray(w, dtype=np.float32)
        arrays[f"b{i}"] = np.asarray(b, dtype=np.float32)
    write_atomic(path, lambda tmp: np.savez(tmp, **arrays), suffix=".npz")


def read_policy_file(path: str | os.PathLike) -> tuple[dict[str, Any], list[tuple[np.ndarray, np.ndarray]]]:
    """Metadata and layers of a policy file; :class:`PolicyLoadError` names any problem."""
    path = Path(path)
    if not path.is_file():
        raise PolicyLoadError(f"policy file '{path}' does not exist")
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(bytes(data["meta"]).decode())
            if meta.get("format") != FORMAT:
                raise PolicyLoadError(f"'{path}' is not a petswarm policy file (format {meta.get('format')!r})")
            if meta.get("format_version") != FORMAT_VERSION:
                raise PolicyLoadError(f"'{path}' has policy format version {meta.get('format_version')}, this petswarm reads {FORMAT_VERSION}")
            layers = [(data[f"w{i}"], data[f"b{i}"]) for i in range(int(meta["num_layers"]))]
    except PolicyLoadError:
        raise
    except (zipfile.BadZipFile, OSError, EOFError, KeyError, ValueError, json.JSONDecodeError) as exc:
        raise PolicyLoadError(f"policy file '{path}' is corrupt or truncated ({type(exc).__name__}: {exc}); re-export or re-train it") from None
    for i, (w, b) in enumerate(layers):
        if w.ndim != 2 or b.shape != (w.shape[0],) or (i > 0 and w.shape[1] != layers[i - 1][0].shape[0]):
            raise PolicyLoadError(f"policy file '{path}' has inconsistent layer shapes at layer {i}")
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(b))):
            raise PolicyLoadError(f"policy file '{path}' has non-finite weights in layer {i}")
    if layers and layers[-1][0].shape[0] != 3:
        raise PolicyLoadError(f"policy file '{path}' outputs {layers[-1][0].shape[0]} values; a slave action has 3")
    return meta, layers


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


class LearnedPolicy(Policy):
    """A saved MLP actor evaluated with numpy (deterministic: the mean action, clipped)."""

    name = "learned"

    def __init__(self, spec: PolicySpec, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                 index: np.ndarray, meta: dict[str, Any] | None = None):
        super().__init__(spec)
        self.layers = [(w.astype(np.float64), b.astype(np.float64)) for w, b in layers]
        self.act_fn = ACTIVATIONS[activation]
        self.index = index
        self.meta = meta or {}
        identity = len(index) == spec.layout.size and np.array_equal(index, np.arange(spec.layout.size))
        self._identity = identity

    @classmethod
    def load(cls, path: str | os.PathLike, spec: PolicySpec) -> LearnedPolicy:
        meta, layers = read_policy_file(path)
        if meta.get("env_name") != ENV_NAME:
            raise PolicyLoadError(f"policy '{path}' was trained on env '{meta.get('env_name')}', this is '{ENV_NAME}'")
        saved = [(str(n), int(s)) for n, s in meta["observation_layout"]]
        index = observation_mapping(saved, spec.layout)
        if layers[0][0].shape[1] != len(index):
            raise PolicyLoadError(f"policy '{path}' expects {layers[0][0].shape[1]} inputs but its layout has {len(index)}")
        if meta.get("activation") not in ACTIVATIONS:
            raise PolicyLoadError(f"policy '{path}' uses unknown activation {meta.get('activation')!r}")
        return cls(spec, layers, meta["activation"], index, meta)

    def forward(self, obs: np.ndarray) -> np.ndarray:
        x = np.asarray(obs, dtype=np.float64)
        x = x if self._identity else x[..., self.index]
        for w, b in self.layers[:-1]:
            x = self.act_fn(x @ w.T + b)
        w, b = self.layers[-1]
        return x @ w.T + b

    def act(self, agent: str, observation: np.ndarray) -> np.ndarray:
        return np.clip(self.forward(observation), -1.0, 1.0).astype(np.float32)

    def act_all(self, observations: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        if not observations:
            return {}
        agents = list(observations)
        out = np.clip(self.forward(np.stack([observations[a] for a in agents])), -1.0, 1.0).astype(np.float32)
        return {a: out[i] for i, a in enumerate(agents)}
