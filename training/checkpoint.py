"""A training checkpoint that runs no code when it is read: ``runs/NAME/checkpoints/latest.npz``.

Stable-Baselines3's own ``model.save`` zip holds a pickled ``data`` entry, and its ``PPO.load``
unpickles it: a crafted checkpoint would run code on ``--resume``. petswarm never calls it.
Its checkpoint is one ``.npz`` file (numpy's zip of arrays, read by
:func:`petswarm_env.files.read_npz`: numbers only, never a pickle), written atomically:

    state                      UTF-8 JSON (a uint8 array): format, format_version, num_timesteps,
                               n_updates, the network (observation size, net_arch, activation), the
                               optimizer's param_groups, numpy's and Python's global RNG states
    policy:<name>              every tensor of the SB3 policy's state_dict (actor, critic, log_std)
    optimizer:<i>:<key>        the Adam state of parameter i (step, exp_avg, exp_avg_sq)
    rng:torch, rng:numpy       torch's CPU RNG state (bytes), numpy's MT19937 key

:func:`restore_checkpoint` puts them into a freshly built model of the run's config (the same
network), after checking that every tensor is there with its shape and finite. The RLlib back end
(``--backend rllib``) writes the same file with ``backend: rllib`` in the state record and its
module's weights (actor, critic, heads) as ``policy:<name>`` (:func:`save_weights_checkpoint`,
:func:`restore_weights`); RLlib's optimizer state is not in it (its moments start afresh on
resume). Each back end refuses the other's checkpoint by name. A run folder that
holds only SB3's old ``latest.zip`` is refused with :data:`OLD_FORMAT_MESSAGE`'s advice; that
file is never opened.
"""

from __future__ import annotations

import json
import os
import random
from pathlib import Path
from typing import Any

import numpy as np
import torch

from petswarm_env.config import ConfigError
from petswarm_env.files import read_npz, write_atomic

CHECKPOINT = "latest.npz"
OLD_SB3_CHECKPOINT = "latest.zip"  # what earlier versions wrote: SB3's pickled format, never read
FORMAT = "petswarm-checkpoint"
FORMAT_VERSION = 1
MAX_BYTES = 1_000_000_000
OLD_FORMAT_MESSAGE = ("'{path}' is a checkpoint of an older petswarm in Stable-Baselines3's pickled format, which can run "
                      "code when loaded, so it is not read; start a new run with another --out (this run's policy.npz "
                      "still works with --policy)")


def checkpoint_path(out: str | os.PathLike) -> Path:
    return Path(out) / "checkpoints" / CHECKPOINT


def has_checkpoint(out: str | os.PathLike) -> bool:
    """Whether the run folder holds a checkpoint of either format."""
    folder = Path(out) / "checkpoints"
    return (folder / CHECKPOINT).exists() or (folder / OLD_SB3_CHECKPOINT).exists()


def save_checkpoint(path: str | os.PathLike, model, activation: str, net_arch: list[int]) -> None:
    """Write ``model`` (an SB3 PPO) to ``path`` atomically: weights, optimizer, counters, RNGs."""
    optim = model.policy.optimizer.state_dict()
    np_state = np.random.get_state()
    state = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "backend": "sb3",
        "num_timesteps": int(model.num_timesteps),
        "n_updates": int(model._n_updates),
        "network": {"observation_size": int(model.observation_space.shape[0]), "net_arch": list(net_arch),
                    "activation": activation},
        "optimizer_param_groups": optim["param_groups"],
        "numpy_rng": {"pos": int(np_state[2]), "has_gauss": int(np_state[3]), "cached_gaussian": float(np_state[4])},
        "python_rng": [random.getstate()[0], list(random.getstate()[1]), random.getstate()[2]],
    }
    arrays = {"state": np.frombuffer(json.dumps(state).encode(), dtype=np.uint8),
              "rng:torch": torch.get_rng_state().numpy(), "rng:numpy": np_state[1]}
    for name, tensor in model.policy.state_dict().items():
        arrays[f"policy:{name}"] = tensor.detach().cpu().numpy()
    for index, per_param in optim["state"].items():
        for key, value in per_param.items():
            arrays[f"optimizer:{index}:{key}"] = torch.as_tensor(value).detach().cpu().numpy()
    write_atomic(path, lambda tmp: np.savez(tmp, **arrays), suffix=".npz")


def read_checkpoint(out: str | os.PathLike) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The state record and the arrays of a run's checkpoint; :class:`ConfigError` (one line,
    naming the file) for a missing, old-format, damaged or foreign file."""
    path = checkpoint_path(out)
    old = path.with_name(OLD_SB3_CHECKPOINT)
    if not path.is_file():
        if old.exists():
            raise ConfigError(OLD_FORMAT_MESSAGE.format(path=old))
        if path.exists() or path.is_symlink() or (path.parent.exists() and not path.parent.is_dir()):
            raise ConfigError(f"cannot resume: '{out}' checkpoints/{CHECKPOINT} is not a regular file (a folder, a device, a "
                              "dangling link, or checkpoints is a file); the run folder is damaged, start a new run with another --out")
        raise ConfigError(f"cannot resume: '{out}' has no checkpoint (checkpoints/{CHECKPOINT}); train without --resume first")
    try:
        arrays = read_npz(path, MAX_BYTES)
    except (ValueError, OSError) as exc:
        raise ConfigError(f"checkpoint '{path}' cannot be read: {exc}; it is damaged or not a petswarm checkpoint "
                          "(start a new run with another --out)") from None
    try:
        state = json.loads(arrays.pop("state").tobytes().decode("utf-8"))
    except (KeyError, ValueError, RecursionError):  # missing, not UTF-8, not JSON, a number beyond 4300 digits
        raise ConfigError(f"checkpoint '{path}' has no readable 'state' record; it is corrupt or not a petswarm "
                          "checkpoint") from None
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        raise ConfigError(f"'{path}' is not a petswarm checkpoint (field 'format' must be {FORMAT!r})")
    if state.get("format_version") != FORMAT_VERSION:
        raise ConfigError(f"checkpoint '{path}' has format version {state.get('format_version')!r}, this petswarm reads "
                          f"{FORMAT_VERSION}; resume it with the petswarm that wrote it")
    n = state.get("num_timesteps")
    if not isinstance(n, int) or isinstance(n, bool) or n < 0:
        raise ConfigError(f"checkpoint '{path}': field 'num_timesteps' must be a whole number >= 0, got {n!r}")
    from petswarm.training.config import MAX_STEPS

    if n > MAX_STEPS:  # no run trains more (training config timesteps); a larger count is damage, not progress
        raise ConfigError(f"checkpoint '{path}': field 'num_timesteps' is {n}, more than the {MAX_STEPS} agent-steps a run may "
                          "train; the checkpoint is damaged, start a new run with another --out")
    return state, arrays


def save_weights_checkpoint(path: str | os.PathLike, weights: dict[str, np.ndarray], num_timesteps: int, backend: str,
                            network: dict[str, Any]) -> None:
    """Write a weights-only checkpoint (the RLlib back end's) to ``path`` atomically: the state
    record (format, ``backend``, ``num_timesteps``, ``network``) and ``policy:<name>`` arrays."""
    state = {"format": FORMAT, "format_version": FORMAT_VERSION, "backend": backend, "num_timesteps": int(num_timesteps),
             "network": network}
    arrays = {"state": np.frombuffer(json.dumps(state).encode(), dtype=np.uint8),
              **{f"policy:{name}": np.asarray(value) for name, value in weights.items()}}
    write_atomic(path, lambda tmp: np.savez(tmp, **arrays), suffix=".npz")


def _check_backend(path: Path, state: dict[str, Any], backend: str) -> None:
    wrote = state.get("backend", "sb3")  # petswarm's first npz checkpoints (SB3 only) had no field
    if wrote != backend:
        raise ConfigError(f"checkpoint '{path}' was written by --backend {wrote}; resume it with --backend {wrote}")


def restore_weights(out: str | os.PathLike, backend: str, expected: dict[str, np.ndarray]) -> dict[str, torch.Tensor]:
    """The ``policy:`` tensors of a weights-only checkpoint of ``backend``, exactly the names,
    shapes and dtypes of ``expected`` (the freshly built module's weights); :class:`ConfigError`."""
    path = checkpoint_path(out)
    state, arrays = read_checkpoint(out)
    _check_backend(path, state, backend)
    return _tensors(path, arrays, "policy:", expected)


def _tensors(path: Path, arrays: dict[str, np.ndarray], prefix: str,
             expected: dict[str, torch.Tensor | np.ndarray]) -> dict[str, torch.Tensor]:
    """The arrays under ``prefix`` as tensors, exactly the names, shapes and dtypes of ``expected``."""
    got = {k[len(prefix):]: v for k, v in arrays.items() if k.startswith(prefix)}
    missing, extra = sorted(set(expected) - set(got)), sorted(set(got) - set(expected))
    if missing or extra:
        raise ConfigError(f"checkpoint '{path}' does not fit the run's network (train_config.yaml ppo.net_arch): "
                          f"{'missing ' + ', '.join(missing) if missing else 'unexpected ' + ', '.join(extra)}")
    out = {}
    for name, ref in expected.items():
        arr = got[name]
        if tuple(arr.shape) != tuple(ref.shape) or str(arr.dtype) != str(ref.dtype).removeprefix("torch."):
            raise ConfigError(f"checkpoint '{path}': '{prefix}{name}' is {arr.dtype} {tuple(arr.shape)}, the run's network "
                              f"has {str(ref.dtype).removeprefix('torch.')} {tuple(ref.shape)}")
        if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
            raise ConfigError(f"checkpoint '{path}': '{prefix}{name}' holds NaN or infinite values; the run diverged, "
                              "start a new run with another --out")
        out[name] = torch.from_numpy(np.array(arr))
    return out


def restore_checkpoint(out: str | os.PathLike, model) -> None:
    """Load the run's checkpoint into ``model``, a fresh PPO built from the run's config:
    weights, optimizer, counters and the global RNG states. Raises :class:`ConfigError`."""
    path = checkpoint_path(out)
    state, arrays = read_checkpoint(out)
    _check_backend(path, state, "sb3")
    model.policy.load_state_dict(_tensors(path, arrays, "policy:", model.policy.state_dict()))
    optimizer = model.policy.optimizer
    fresh = optimizer.state_dict()
    groups = state.get("optimizer_param_groups")
    if not isinstance(groups, list) or len(groups) != len(fresh["param_groups"]):
        raise ConfigError(f"checkpoint '{path}': field 'optimizer_param_groups' does not fit the run's optimizer")
    params = [p for g in fresh["param_groups"] for p in g["params"]]
    kinds = {"step": torch.zeros((), dtype=torch.float32)}
    expected = {f"{i}:{k}": (kinds[k] if k in kinds else p) for i, p in zip(params, model.policy.parameters())
                for k in ("step", "exp_avg", "exp_avg_sq")} if any(k.startswith("optimizer:") for k in arrays) else {}
    tensors = _tensors(path, arrays, "optimizer:", {k: v.detach() for k, v in expected.items()})
    per_param: dict[int, dict[str, torch.Tensor]] = {}
    for key, tensor in tensors.items():
        index, name = key.split(":")
        per_param.setdefault(int(index), {})[name] = tensor
    try:
        optimizer.load_state_dict({"state": per_param, "param_groups": groups})
        torch.set_rng_state(torch.from_numpy(np.array(arrays["rng:torch"], dtype=np.uint8)))
        rng = state["numpy_rng"]
        np.random.set_state(("MT19937", np.array(arrays["rng:numpy"], dtype=np.uint32), rng["pos"], rng["has_gauss"],
                             rng["cached_gaussian"]))
        version, internal, gauss = state["python_rng"]
        random.setstate((version, tuple(internal), gauss))
    except (KeyError, TypeError, ValueError, RuntimeError) as exc:
        raise ConfigError(f"checkpoint '{path}' has a damaged optimizer or RNG state ({type(exc).__name__}: {exc})") from None
    model.num_timesteps = state["num_timesteps"]
    model._n_updates = int(state.get("n_updates", 0))
