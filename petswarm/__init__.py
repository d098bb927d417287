"""petswarm: the project's import package.

The environment's public name is :mod:`petswarm_env`; everything else the distribution installs
lives under ``petswarm``: ``petswarm.baselines`` (the scripted reference, learned policies),
``petswarm.training``, ``petswarm.evaluation``, ``petswarm.experiments`` (the papers'
measurements), ``petswarm.bench``, ``petswarm.cli`` (the ``petswarm`` command) and the shipped
configs and examples (:func:`shipped`). In the repository these are the top-level folders of the
same names; ``pyproject.toml`` maps them under ``petswarm`` (``package-dir``).
"""

from __future__ import annotations

from pathlib import Path

__version__ = "1.0.0"
__all__ = ["__version__", "shipped", "shipped_configs"]

_HERE = Path(__file__).resolve().parent


def _shipped_root(name: str) -> Path:
    """The folder ``name`` (``configs`` or ``examples``): inside the installed package (a wheel),
    else the repository's top-level folder (a source tree or an editable install)."""
    for base in (_HERE / name, _HERE.parent / name):
        if base.is_dir():
            return base
    raise FileNotFoundError(f"petswarm: the shipped '{name}' folder is missing from {_HERE}; reinstall petswarm (pip install petswarm)")


def shipped_configs() -> Path:
    """The folder of the shipped configs (``default.yaml``, ``train/*.yaml``, ``eval/grid.yaml``)."""
    return _shipped_root("configs")


def shipped(path: str | Path) -> Path | None:
    """A shipped config or example named by ``path``, or None when there is none.

    ``path`` may be written as in the repository (``configs/train/generalize.yaml``,
    ``examples/torchrl_collect.py``), relative to the configs folder (``train/generalize.yaml``),
    or by its name alone (``train/generalize``, ``generalize``, ``grid``)."""
    text = str(path).replace("\\", "/")
    if not text or ".." in Path(text).parts or Path(text).is_absolute():
        return None
    for prefix, root_name in (("configs/", "configs"), ("examples/", "examples")):
        if text.startswith(prefix):
            candidate = _shipped_root(root_name) / text[len(prefix):]
            return candidate if candidate.is_file() else None
    configs = shipped_configs()
    for candidate in (configs / text, configs / f"{text}.yaml"):
        if candidate.is_file():
            return candidate
    if "/" not in text:  # a bare name: train/NAME.yaml or eval/NAME.yaml
        found = [p for p in sorted(configs.glob(f"*/{text}.yaml")) + sorted(configs.glob(f"*/{text}")) if p.is_file()]
        if len(found) == 1:
            return found[0]
    return None
