"""The comparison grid's file (``petswarm eval --grid configs/eval/grid.yaml``): read, validated,
expanded into cells.

A grid file names a *candidate* policy (``learned``: the shipped model, or a ``.npz`` path) and a
*reference* (``scripted``), the episodes per cell and the base seed, config overrides common to
every cell (``set``), and a list of cell entries. An entry is one cell (its ``set`` overrides) or,
with ``product``, the Cartesian product of the listed values of some keys (each combination one
cell, over the entry's ``set``); its ``team`` says who drives the slaves in the candidate's run:
``policy`` for every slave not named in ``mix`` (``candidate``, ``reference`` or a policy name),
``mix`` one robot each (``{robot_2: candidate}``). The reference's run of a cell always has every
slave driven by the reference, on the same seeds. A cell is therefore just config overrides plus a
team, so a scenario added later is one more entry (``set: {user.scenario: heterogeneous}``).

Every problem is found before anything runs and reported in one line naming the file, the cell
and the fix (:class:`~petswarm_env.config.ConfigError`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError

from petswarm_env.config import ConfigError, Config, describe_value, flatten_dotted, load_config, read_yaml

ROLES = ("candidate", "reference")  # the team words of a grid file: the grid's two policies


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class TeamSpec(_Strict):
    policy: str = "candidate"
    mix: dict[str, str] = Field(default_factory=dict)


class CellEntry(_Strict):
    name: str | None = None
    set: dict[str, Any] = Field(default_factory=dict)
    product: dict[str, list[Any]] = Field(default_factory=dict)
    team: TeamSpec = Field(default_factory=TeamSpec)


# a grid's size: the committed grid has 55 cells of 5 episodes; every cell's config is built before
# anything runs (about 20 ms each), so a product of 10^8 cells is refused by name, never expanded
MAX_CELLS = 2_000
MAX_EPISODES = 10_000  # per cell
MAX_RUNS = 200_000  # cells x episodes x 2 (candidate and reference): about a week of one core


class GridFile(_Strict):
    seed: int = Field(ge=0, le=2**63 - 1 - MAX_EPISODES)
    episodes: int = Field(ge=1, le=MAX_EPISODES)
    candidate: str = "learned"
    reference: str = "scripted"
    target_ratio: float = Field(default=0.8, gt=0, le=100.0)
    metric: Literal["formation_hold_rmse_m", "formation_rmse_m"] = "formation_hold_rmse_m"
    others_tolerance: float = Field(default=0.1, ge=0, le=10.0)
    set: dict[str, Any] = Field(default_factory=dict)
    cells: list[CellEntry] = Field(min_length=1, max_length=MAX_CELLS)


_ALLOWED = {
    (): sorted(GridFile.model_fields),
    ("cells",): sorted(CellEntry.model_fields),
    ("cells", "team"): sorted(TeamSpec.model_fields),
}


@dataclass(frozen=True)
class Cell:
    """One cell of the grid: its name, its overrides (over the grid's ``set``), its candidate team
    (policy names resolved: ``policy`` and ``mix``), and its resolved config."""

    index: int
    name: str
    overrides: dict[str, Any]
    policy: str
    mix: dict[str, str]
    group: str
    axes: dict[str, Any] = field(default_factory=dict)  # the product keys' values of this cell (the heatmap's axes)
    config: Config | None = None

    @property
    def team(self) -> dict[str, Any]:
        return {"policy": self.policy, "mix": dict(self.mix)}


@dataclass(frozen=True)
class Grid:
    path: str
    seed: int
    episodes: int
    candidate: str
    reference: str
    target_ratio: float
    base: dict[str, Any]
    cells: list[Cell]
    metric: str = "formation_hold_rmse_m"  # what a cell is judged on (evaluation/grid.py, SCORED)
    others_tolerance: float = 0.1  # a mixed cell: how much worse the other robots may hold (ratio <= 1 + this)

    def seeds(self) -> list[int]:
        """Every cell's seeds: ``seed .. seed + episodes - 1`` (the same for both runs of a cell, so they pair up)."""
        return list(range(self.seed, self.seed + self.episodes))


def _where(path: str, loc: tuple, entries: list[Any]) -> str:
    """``grid.yaml: cell 3 ('zigzag row')`` from a pydantic location."""
    if len(loc) >= 2 and loc[0] == "cells" and isinstance(loc[1], int):
        entry = entries[loc[1]] if loc[1] < len(entries) else None
        name = entry.get("name") if isinstance(entry, dict) else None
        return f"{path}: cell entry {loc[1]}" + (f" ('{name}')" if name else "")
    return path


def _one_line(exc: ValidationError, path: str, raw: dict[str, Any]) -> str:
    errors = exc.errors()
    err = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])  # a misspelt key explains a missing one
    loc = tuple(err["loc"])
    entries = raw.get("cells") if isinstance(raw.get("cells"), list) else []
    where = _where(path, loc, entries)
    shape = tuple(p for p in loc if not isinstance(p, int))
    key = ".".join(str(p) for p in loc if not isinstance(p, int)) or "(file)"
    if err["type"] == "extra_forbidden":
        allowed = _ALLOWED.get(shape[:-1], [])
        return f"{where}: unknown key '{shape[-1]}'; allowed keys: {', '.join(allowed)}"
    if err["type"] == "missing":
        return f"{where}: '{key}' is missing; give it (see configs/eval/grid.yaml)"
    return f"{where}: bad value for '{key}': {err['msg']} (got {describe_value(err.get('input'))})"


def _policy_of(word: str, grid: GridFile) -> str:
    return grid.candidate if word == "candidate" else grid.reference if word == "reference" else word


def _check_policy(word: str, what: str) -> None:
    from petswarm.baselines.registry import POLICY_NAMES
    from petswarm.training.teacher import TEACHER_NAME, is_teacher, teacher_gains_of

    if word in ROLES or word in POLICY_NAMES:
        return
    if is_teacher(word):  # the teacher: a ceiling (docs/training.md)
        try:
            teacher_gains_of(word)
        except ConfigError as exc:
            raise ConfigError(f"{what}: {exc}") from None
        return
    if word.endswith(".npz"):
        if not Path(word).is_file():
            raise ConfigError(f"{what}: policy file '{word}' does not exist; give an existing .npz policy file")
        return
    raise ConfigError(f"{what}: unknown policy '{word}'; use candidate, reference, {', '.join(POLICY_NAMES)}, "
                      f"{TEACHER_NAME}[:TRAIN_CONFIG] or a .npz path")


def _label(value: Any) -> str:
    return str(value)


def _expand(entry: CellEntry, k: int) -> list[tuple[str, dict[str, Any], dict[str, Any]]]:
    """An entry's cells: (name, overrides, product axes)."""
    prefix = entry.name or f"entry {k}"
    if not entry.product:
        return [(prefix, dict(entry.set), {})]
    keys = list(entry.product)
    out = []
    for values in itertools.product(*(entry.product[key] for key in keys)):
        axes = dict(zip(keys, values))
        name = prefix + " " + " ".join(f"{key.rsplit('.', 1)[-1]}={_label(v)}" for key, v in axes.items())
        out.append((name, {**entry.set, **axes}, axes))
    return out


def _check_entry(entry: CellEntry, where: str) -> None:
    for key, values in entry.product.items():
        if not values:
            raise ConfigError(f"{where}: product '{key}' lists no values; give at least one")
        if key in entry.set:
            raise ConfigError(f"{where}: '{key}' is both in set and in product; keep it in one of them")
    for robot in entry.team.mix:
        if not robot.startswith("robot_") or not robot[6:].isdigit():
            raise ConfigError(f"{where}: team.mix key '{robot}' must name a robot, e.g. robot_2")
    _check_policy(entry.team.policy, f"{where}: team.policy")
    for robot, word in entry.team.mix.items():
        _check_policy(word, f"{where}: team.mix.{robot}")


def load_grid(path: str, base_config: Config | None = None, candidate: str | None = None,
              episodes: int | None = None, seed: int | None = None) -> Grid:
    """Read and validate the grid file at ``path`` and build every cell's config over
    ``base_config`` (default: configs/default.yaml) and the file's ``set``. ``candidate``,
    ``episodes`` and ``seed`` replace the file's (the command line's ``--policy``, ``--episodes``,
    ``--seed``). Raises :class:`ConfigError` with one line naming the cell and the fix."""
    raw = read_yaml(path, "grid file")
    try:
        grid = GridFile.model_validate(raw)
    except ValidationError as exc:
        raise ConfigError(_one_line(exc, path, raw)) from None
    updates = {k: v for k, v in (("candidate", candidate), ("episodes", episodes), ("seed", seed)) if v is not None}
    grid = grid.model_copy(update=updates)
    _check_policy(grid.candidate, f"{path}: candidate")
    _check_policy(grid.reference, f"{path}: reference")
    if grid.candidate in ROLES or grid.reference in ROLES:
        raise ConfigError(f"{path}: candidate and reference must name policies (e.g. learned, scripted), not roles")
    base = flatten_dotted(base_config.to_dict()) if base_config is not None else {}
    try:
        load_config(overrides={**base, **grid.set})
    except ConfigError as exc:
        raise ConfigError(f"{path}: set: {exc}") from None
    total = 0
    for k, entry in enumerate(grid.cells):  # the grid's size, before any cell is expanded
        size = math.prod(len(v) for v in entry.product.values()) if entry.product else 1
        total += size
        if total > MAX_CELLS:
            where = f"{path}: cell entry {k}" + (f" ('{entry.name}')" if entry.name else "")
            raise ConfigError(f"{where}: the grid reaches {total if size < 10**12 else 'more than 10^12'} cells, more than the "
                              f"{MAX_CELLS} a grid may have (product: {' x '.join(str(len(v)) for v in entry.product.values()) or 1}); "
                              "list fewer values or split the grid")
    if total * grid.episodes * 2 > MAX_RUNS:
        raise ConfigError(f"{path}: {total} cells x {grid.episodes} episodes x 2 teams is {total * grid.episodes * 2} episodes, "
                          f"more than the {MAX_RUNS} a grid may run; lower episodes or the number of cells")
    cells: list[Cell] = []
    names: set[str] = set()
    for k, entry in enumerate(grid.cells):
        where = f"{path}: cell entry {k}" + (f" ('{entry.name}')" if entry.name else "")
        _check_entry(entry, where)
        for name, overrides, axes in _expand(entry, k):
            if name in names:
                raise ConfigError(f"{path}: two cells are named '{name}'; give the entries distinct names")
            names.add(name)
            try:
                cfg = load_config(overrides={**base, **grid.set, **overrides})
            except ConfigError as exc:
                raise ConfigError(f"{path}: cell '{name}': {exc}") from None
            mix = {r: _policy_of(w, grid) for r, w in entry.team.mix.items()}
            _check_robots(cfg, mix, f"{path}: cell '{name}'")
            cells.append(Cell(len(cells), name, overrides, _policy_of(entry.team.policy, grid), mix,
                              entry.name or f"entry {k}", axes, cfg))
    return Grid(path, grid.seed, grid.episodes, grid.candidate, grid.reference, grid.target_ratio,
                dict(grid.set), cells, grid.metric, grid.others_tolerance)


def _check_robots(cfg: Config, mix: dict[str, str], where: str) -> None:
    """``mix`` names only robots that can be slaves of this cell's swarm (the env's possible agents)."""
    if not mix:
        return
    from petswarm_env.env import PetSwarmEnv

    env = PetSwarmEnv(cfg)
    try:
        bad = sorted(set(mix) - set(env.possible_agents))
        if bad:
            raise ConfigError(f"{where}: team.mix names {', '.join(bad)}, not a slave of this swarm; "
                              f"choose from {', '.join(env.possible_agents)}")
    finally:
        env.close()


# -- an earlier result for --resume: every kept cell checked field by field before anything runs ------
class _Record(BaseModel):
    model_config = ConfigDict(extra="allow", strict=True, allow_inf_nan=True)


Count = Field(ge=0, le=10**12)


def _not_negative(x: float) -> float:
    if x < 0:  # NaN passes: no formation, no ratio
        raise ValueError("Input should not be negative (an error or a ratio of errors)")
    return x


Figure = Annotated[float, AfterValidator(_not_negative)]  # NaN allowed (no formation), null not: the summaries compute with it


class _EpisodeRecord(_Record):
    seed: int = Field(ge=0)
    formation_rmse_m: Figure


class _RunRecord(_Record):
    label: str
    episodes: int = Count
    formation_rmse_m: Figure
    collisions: int = Count
    per_episode: list[_EpisodeRecord]


class _CellRecord(_Record):
    key: str
    name: str
    ratio: Figure
    median_ratio: Figure | None = None
    episodes_better: int = Count
    meets_target: bool
    collisions_not_more: bool
    wall_s: float = Field(default=0.0, ge=0, le=10**9)
    candidate: _RunRecord
    reference: _RunRecord


RESUME_FIX = "repair the file or write the grid to another --json without --resume"


def check_previous_cells(path: str, cells: list[Any], what: str = "--resume", fix: str = RESUME_FIX) -> None:
    """Every cell of an earlier grid result (``eval --grid --resume``; the report reads the same
    records, ``what``/``fix`` its words) must be a whole cell record (the fields a kept cell is
    summarised and reported from, of their types, errors and ratios never negative), or the command
    is refused before it runs or rewrites anything: a damaged file is never replaced by a partial
    one. Raises :class:`ConfigError` naming the file, the cell and the field."""
    for k, cell in enumerate(cells):
        if not isinstance(cell, dict):
            raise ConfigError(f"{what}: '{path}' cell {k} is {describe_value(cell)}, not a cell record; {fix}")
        try:
            record = _CellRecord.model_validate(cell)
        except ValidationError as exc:
            err = exc.errors()[0]
            field = ".".join(str(p) for p in err["loc"]) or "(cell)"
            name = cell.get("name") if isinstance(cell.get("name"), str) else None
            problem = ("is missing" if err["type"] == "missing" else "must be a JSON object" if err["type"] in ("model_type", "dict_type")
                       else f"{err['msg'].removeprefix('Value error, ')[0].lower()}{err['msg'].removeprefix('Value error, ')[1:]} "
                       f"(got {describe_value(err.get('input'))})")
            raise ConfigError(f"{what}: '{path}' cell {k}" + (f" ('{name[:60]}')" if name else "") +
                              f": field '{field}' {problem}; {fix}") from None
        for run in ("candidate", "reference"):
            r = getattr(record, run)
            if len(r.per_episode) != r.episodes:
                raise ConfigError(f"{what}: '{path}' cell {k}: field '{run}.per_episode' holds {len(r.per_episode)} episodes, "
                                  f"'{run}.episodes' says {r.episodes}; {fix}")
