"""The compiled core: the modules that run for every event of the clock, compiled to C at install.

Each of them is one ordinary ``.py`` file written in Cython's pure-Python mode (``import cython``,
``@cython.cclass``, typed attributes, ``@cython.cfunc``): the interpreter runs it as it is, and
``setup.py`` compiles the same file to a C extension (``cythonize``) when the package is
installed (``pip install .``, ``pip install -e .``, ``bash scripts/setup.sh``) or built in place
(``python setup.py build_ext --inplace``). The built ``.so`` files are not in git.

At import (``petswarm_env/__init__.py`` calls :func:`load`), every module of :data:`COMPILED` must
be its compiled form, and not older than its source; otherwise the import fails with one line that
names the fix. ``PETSWARM_PURE_PYTHON=1`` runs the interpreted form of every module on purpose (the
oracle: the tests hold the compiled form to it, bit for bit), ignoring any built extension.

This file is read by ``setup.py`` (:data:`COMPILED`) and must stay importable without the package.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import os
import sys
from pathlib import Path

# the modules compiled to C, in the order they are built
COMPILED: tuple[str, ...] = (
    "petswarm_env.sim.clock",
    "petswarm_env.sim.draws",
    "petswarm_env.sim.health",
    "petswarm_env.comms.radio",
    "petswarm_env.middleware.knowledge",
    "petswarm_env.middleware.station",
    "petswarm_env.middleware.sequence",
    "petswarm_env.middleware.token_ring",
    "petswarm_env.sim.battery",
    "petswarm_env.sim.body",
    "petswarm_env.sim.geometry",
    "petswarm_env.sim.sensors",
    "petswarm_env.comms.ir",
    "petswarm_env.observe",
    "petswarm_env.wearables.belt_window",
    "petswarm_env.wearables.belt",
    "petswarm_env.wearables.lf",
    "petswarm_env.comms.ir_channel",
    "petswarm_env.middleware.node",
    "petswarm_env.middleware.fleet",
    "petswarm_env.middleware.diagnosis",
    "petswarm_env.control.arbiter",
    "petswarm_env.control.master",
    "petswarm_env.middleware.user_session",
    "petswarm_env.sim.robot",
    "petswarm_env.references",
    "petswarm_env.reward",
    "petswarm_env.step_kernel",
)

PURE_ENV = "PETSWARM_PURE_PYTHON"  # "1": run the interpreted form of every module of COMPILED
FIX = ("run: pip install -e . (or bash scripts/setup.sh, or in a checkout python setup.py build_ext --inplace); "
       "PETSWARM_PURE_PYTHON=1 runs the slow interpreted form instead")

_ROOT = Path(__file__).resolve().parent.parent  # the directory that holds petswarm_env/


def pure() -> bool:
    """True when the interpreted form is asked for (``PETSWARM_PURE_PYTHON=1``)."""
    return os.environ.get(PURE_ENV, "") not in ("", "0")


def source_path(module: str) -> Path:
    return _ROOT.joinpath(*module.split(".")).with_suffix(".py")


def extension_path(module: str) -> Path | None:
    """The built extension of ``module`` beside its source, or None."""
    src = source_path(module)
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        p = src.with_suffix(suffix)
        if p.exists():
            return p
    return None


class _SourceFirst(importlib.abc.MetaPathFinder):
    """Imports the ``.py`` of a module of :data:`COMPILED` even where its extension is built
    (Python's own finder prefers the extension)."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname in COMPILED:
            return importlib.util.spec_from_file_location(fullname, source_path(fullname))
        return None


def problem() -> str | None:
    """What is wrong with the compiled core (missing or stale extension), or None."""
    missing, stale = [], []
    for module in COMPILED:
        ext = extension_path(module)
        if ext is None:
            missing.append(module)
        elif any(src.exists() and src.stat().st_mtime > ext.stat().st_mtime + 1.0  # its .py, or its .pxd
                 for src in (source_path(module), source_path(module).with_suffix(".pxd"))):
            stale.append(module)
    if missing:
        return f"petswarm: compiled core not built ({', '.join(missing)}); {FIX}"
    if stale:
        return f"petswarm: compiled core older than its source ({', '.join(stale)}); {FIX}"
    return None


def load() -> None:
    """Called first by ``petswarm_env/__init__.py``: the interpreted form when asked for, else
    the compiled core, or an ImportError of one line naming the fix."""
    if pure():
        if not any(isinstance(f, _SourceFirst) for f in sys.meta_path):
            sys.meta_path.insert(0, _SourceFirst())
        return
    message = problem()
    if message is not None:
        raise ImportError(message)


def compiled_modules() -> dict[str, bool]:
    """Each module of :data:`COMPILED` (imported): whether it runs as compiled code."""
    import importlib

    return {m: bool(getattr(importlib.import_module(m), "COMPILED", False)) for m in COMPILED}
