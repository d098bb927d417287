"""A run folder checked field by field before ``petswarm train --resume`` writes anything into it:
the checkpoint's state record and RNG arrays (:mod:`petswarm.training.checkpoint`) and ``train_log.json``
(:mod:`petswarm.training.train`). A damaged field is refused in one line naming the file and the field;
the folder stays as it was (no train_config.yaml rewritten, no policy or checkpoint replaced).

The weights themselves (names, shapes, dtypes, finite) are checked against the freshly built
network by :func:`petswarm.training.checkpoint.restore_checkpoint`, which also runs before anything is written.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from petswarm_env.config import ConfigError, describe_value


class _Record(BaseModel):
    model_config = ConfigDict(extra="allow", strict=True, allow_inf_nan=False)


Steps = Field(ge=0, le=10**15)  # agent-steps: far beyond any run (10^15 at 10^5 steps/s is three centuries)


class _Network(_Record):
    observation_size: int = Field(ge=1, le=10**6)
    net_arch: list[int] = Field(max_length=64)
    activation: Literal["tanh", "relu"]


class _ParamGroup(_Record):
    lr: float = Field(ge=0, le=10.0)
    betas: list[float] | None = Field(default=None, min_length=2, max_length=2)
    eps: float = Field(default=1e-8, gt=0, le=1.0)
    weight_decay: float = Field(default=0.0, ge=0, le=10.0)
    params: list[int]


class _NumpyRng(_Record):
    pos: int = Field(ge=0, le=624)  # MT19937's position in its 624-word key
    has_gauss: int = Field(ge=0, le=1)
    cached_gaussian: float


class _State(_Record):
    backend: Literal["sb3", "rllib"] = "sb3"
    num_timesteps: int = Steps
    n_updates: int = Field(default=0, ge=0, le=10**12)
    network: _Network | None = None


class _Sb3State(_State):
    optimizer_param_groups: list[_ParamGroup] = Field(min_length=1, max_length=64)
    numpy_rng: _NumpyRng
    python_rng: list[Any] = Field(min_length=3, max_length=3)  # version, 625 words, gauss (random.getstate)


class _Evaluation(_Record):
    timesteps: int = Steps
    formation_rmse_m: float | None = None


class _Resume(_Record):
    from_timesteps: int = Steps


class _TrainLog(_Record):
    timesteps: int = Steps
    wall_time_s: float = Field(ge=0, le=10**10)
    evaluations: list[_Evaluation]
    scripted_eval_rmse_m: float | None
    resumes: list[_Resume] = Field(default_factory=list)
    pretrain: dict[str, Any] | None = None
    command: str = ""
    active_agent_steps: int = Field(default=0, ge=0, le=10**15)  # SB3 runs count it, RLlib runs do not


def _problem(exc: ValidationError) -> str:
    err = exc.errors()[0]
    field = ".".join(str(p) for p in err["loc"]) or "(record)"
    if err["type"] == "missing":
        return f"field '{field}' is missing"
    if err["type"] in ("model_type", "dict_type"):
        return f"field '{field}' must be a JSON object (got {describe_value(err.get('input'))})"
    return f"field '{field}': {err['msg'][0].lower()}{err['msg'][1:]} (got {describe_value(err.get('input'))})"


def check_train_log(path: Path, log: Any) -> None:
    """``train_log.json`` of a run to resume: an object with every field the resumed run reads
    and appends to, of its type; :class:`ConfigError` naming the file and the field."""
    if not isinstance(log, dict):
        raise ConfigError(f"cannot resume: '{path}' is not a train log (a JSON object); start a new run with another --out")
    try:
        _TrainLog.model_validate(log)
    except ValidationError as exc:
        raise ConfigError(f"cannot resume: '{path}' is damaged: {_problem(exc)}; repair it or start a new run with "
                          "another --out") from None
    if log.get("pretrain") is not None and not isinstance(log["pretrain"].get("samples", 0), int):
        raise ConfigError(f"cannot resume: '{path}' is damaged: field 'pretrain.samples' must be a whole number")


def check_checkpoint_state(path: Path, state: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """The state record and RNG arrays of a checkpoint (``backend`` sb3: the optimizer's param
    groups and the three RNG states; rllib: weights only), every field of its type and range, and
    numbers finite; :class:`ConfigError` naming the file and the field."""
    model = _Sb3State if state.get("backend", "sb3") == "sb3" else _State
    try:
        record = model.model_validate(state)
    except ValidationError as exc:
        raise ConfigError(f"checkpoint '{path}' is damaged: {_problem(exc)}; start a new run with another --out") from None
    if isinstance(record, _Sb3State):
        version, internal, gauss = record.python_rng
        if (not isinstance(version, int) or not isinstance(internal, list) or len(internal) != 625
                or not all(isinstance(x, int) and not isinstance(x, bool) and 0 <= x < 2**32 for x in internal)
                or not (gauss is None or isinstance(gauss, float))):
            raise ConfigError(f"checkpoint '{path}' is damaged: field 'python_rng' is not a Mersenne Twister state; start a new run")
        for key, dtype, size in (("rng:torch", np.uint8, None), ("rng:numpy", np.uint32, 624)):
            arr = arrays.get(key)
            if arr is None or arr.ndim != 1 or (size is not None and arr.shape[0] != size) or not np.can_cast(arr.dtype, dtype):
                got = "missing" if arr is None else f"{arr.dtype} {tuple(arr.shape)}"
                raise ConfigError(f"checkpoint '{path}' is damaged: array '{key}' is {got}; start a new run with another --out")
        for k, group in enumerate(record.optimizer_param_groups):
            if group.betas is not None and not all(0 <= b < 1 for b in group.betas):
                raise ConfigError(f"checkpoint '{path}' is damaged: field 'optimizer_param_groups.{k}.betas' must be in [0, 1)")
    for key, arr in arrays.items():
        if key.startswith("optimizer:") and arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
            raise ConfigError(f"checkpoint '{path}': '{key}' holds NaN or infinite values; start a new run with another --out")
