"""Writing files: the one atomic writer and the one JSON sanitiser of the project.

Every file petswarm writes (run and eval JSON, reports, benchmark pages and plots, policy files,
checkpoints, GIFs) goes through :func:`write_atomic`: the content is written to a temporary file
in the target's folder, given ordinary permissions (``0o666`` less the umask, as ``open`` would
create it: ``mkstemp`` makes it ``0o600``), then moved into place with :func:`os.replace`. A
reader sees the old file or the new one, never half of one; on an error the temporary file is
removed and the old file stays.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_atomic(path: str | os.PathLike, write: Callable[[str], Any], suffix: str | None = None) -> Path:
    """Call ``write(tmp)`` to fill a temporary file beside ``path``, then rename it to ``path``.

    The temporary file is ``.<name>.<random><suffix>``, ``suffix`` being the target's own unless
    given: writers that add a suffix the name lacks (``np.savez`` adds ``.npz``, SB3's ``save``
    ``.zip``) must find it there. Parent folders are created. Returns ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix if suffix is None else suffix
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)

    return write_atomic(path, write)


def write_json_atomic(path: str | os.PathLike, data: Any) -> Path:
    """Write ``data`` as indented JSON (and a final newline) to ``path`` atomically. NaN and
    infinities are written as JavaScript's ``NaN``/``Infinity``, as :mod:`json` does; pass the
    data through :func:`jsonable` first for strict JSON."""
    return write_text_atomic(path, json.dumps(data, indent=2, allow_nan=True) + "\n")


def jsonable(x: Any) -> Any:
    """Plain JSON types: numpy scalars and arrays as numbers and lists, tuples as lists, keys as
    strings, and a float that is not finite as ``None`` (strict JSON has no NaN)."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    return x
