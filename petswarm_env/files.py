"""Reading and writing files: the one atomic writer, the one JSON sanitiser, the one JSON Lines
appender, the one safe reader of ``.npz`` arrays, and the signals that end a command cleanly.

Every file petswarm writes (run and eval JSON, reports, benchmark pages and plots, policy files,
checkpoints, GIFs) goes through :func:`write_atomic`: the content is written to a temporary file
in the target's folder, given ordinary permissions (``0o666`` less the umask, as ``open`` would
create it: ``mkstemp`` makes it ``0o600``), then moved into place with :func:`os.replace`. A
reader sees the old file or the new one, never half of one; on an error, Ctrl-C or a SIGTERM
(with :func:`exit_cleanly_on_signals`, which the CLI installs) the temporary file is removed and
the old file stays.

A temporary file is named ``.<name>.petswarm-tmp-<pid>-<random><suffix>`` (:data:`TEMP_PATTERN`).
A process killed with SIGKILL cannot remove its own, so the first write of a later process into
the same folder removes every file of that pattern whose process is gone and which belongs to
the same user (:func:`remove_stale_temps`); no other file is ever touched.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import signal
import sys
import tempfile
import threading
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

TEMP_TAG = "petswarm-tmp"
# .<target name>.petswarm-tmp-<pid>-<8 random characters of mkstemp><the target's suffix, if any>
TEMP_PATTERN = re.compile(r"^\.(?P<target>.+)\." + TEMP_TAG + r"-(?P<pid>\d+)-[a-z0-9_]{8}(\.[A-Za-z0-9]+)?$")
_cleaned_folders: set[str] = set()


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive
        return True
    return True


def remove_stale_temps(folder: str | os.PathLike) -> list[Path]:
    """Remove the temporary files of :func:`write_atomic` in ``folder`` left by a process that
    no longer runs (killed with SIGKILL, or a power cut): regular files named by
    :data:`TEMP_PATTERN`, owned by this user, whose process id is not alive. Returns them."""
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        m = TEMP_PATTERN.match(entry.name)
        if m is None or not entry.is_file(follow_symlinks=False):
            continue
        try:
            if entry.stat(follow_symlinks=False).st_uid != os.getuid() or _process_alive(int(m["pid"])):
                continue
            os.unlink(entry.path)
        except OSError:
            continue
        removed.append(Path(entry.path))
    return removed


def write_atomic(path: str | os.PathLike, write: Callable[[str], Any], suffix: str | None = None) -> Path:
    """Call ``write(tmp)`` to fill a temporary file beside ``path``, then rename it to ``path``.

    The temporary file is ``.<name>.petswarm-tmp-<pid>-<random><suffix>``, ``suffix`` being the
    target's own unless given: writers that add a suffix the name lacks (``np.savez`` adds
    ``.npz``) must find it there. Parent folders are created; the first write into a folder
    removes the stale temporary files there (:func:`remove_stale_temps`). Returns ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    folder = os.path.abspath(path.parent)
    if folder not in _cleaned_folders:
        _cleaned_folders.add(folder)
        remove_stale_temps(folder)
    suffix = path.suffix if suffix is None else suffix
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{TEMP_TAG}-{os.getpid()}-", suffix=suffix, dir=path.parent)
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


def _nearest_existing(p: Path) -> Path:
    for parent in (p, *p.parents):
        if parent.exists():
            return parent
    return Path(".")


def _can_write_into(folder: Path) -> str | None:
    """Why no file can be created in the existing folder ``folder`` (None if one can): the
    permissions, then a real try (a read-only mount passes ``os.access`` for root only on paper)."""
    if not os.access(folder, os.W_OK | os.X_OK):
        return "permission denied"
    try:
        fd, probe = tempfile.mkstemp(prefix=f".petswarm-probe-{os.getpid()}-", dir=folder)
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    os.unlink(probe)
    return None


def check_output_path(path: str | os.PathLike | None, flag: str, folder: bool = False) -> None:
    """Refuse, before a command does its work, an output it could not write at the end: a file
    where a folder is wanted (``folder``), a folder where a file is, a path under a file, or a
    place where this user cannot create a file (the nearest existing folder is tried: a probe file
    is created and removed there; nothing else is touched). Raises ``ValueError`` naming
    ``flag``; ``None`` passes."""
    if path is None:
        return
    text, p = os.fspath(path), Path(path)
    if folder and p.exists() and not p.is_dir():
        raise ValueError(f"{flag} '{text}' is a file; name a folder (it is created if missing)")
    if not folder and (p.is_dir() or text.endswith(os.sep)):
        raise ValueError(f"{flag} '{text}' is a folder; name a file, e.g. {os.path.join(text, 'results.json')}")
    if not folder and p.exists() and not p.is_file():
        raise ValueError(f"{flag} '{text}' is not a regular file (a device or a pipe); name a file")
    for parent in (p, *p.parents) if folder else p.parents:
        if parent.exists():
            if not parent.is_dir():
                raise ValueError(f"{flag} '{text}' cannot be written: '{parent}' is a file, not a folder")
            break
    where = _nearest_existing(p if folder else p.parent)
    why = _can_write_into(where)
    if why is None and not folder and p.is_file() and not os.access(p, os.W_OK):
        why = "the file is read-only"
    if why is not None:
        raise ValueError(f"{flag} '{text}' cannot be written ({why} in '{where}'); name a writable place")


def _same(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
    except OSError:
        pass
    return os.path.realpath(a) == os.path.realpath(b)


def check_distinct_paths(inputs: dict[str, Any], outputs: dict[str, Any]) -> None:
    """Refuse an output that is also an input of the command (it would destroy it) or another
    output (one would overwrite the other). ``inputs`` and ``outputs`` map a flag to a path
    (``None`` skipped; a list of paths allowed for inputs). Raises ``ValueError`` naming both flags."""
    ins = [(flag, q) for flag, v in inputs.items() for q in (v if isinstance(v, (list, tuple)) else [v]) if q is not None]
    outs = [(flag, q) for flag, q in outputs.items() if q is not None]
    for k, (oflag, out) in enumerate(outs):
        for iflag, inp in ins:
            if _same(out, inp):
                raise ValueError(f"{oflag} '{os.fspath(out)}' is also the input {iflag}: writing it would destroy the input; "
                                 f"name another {oflag}")
        for oflag2, out2 in outs[k + 1:]:
            if _same(out, out2):
                raise ValueError(f"{oflag} and {oflag2} both name '{os.fspath(out)}': one would overwrite the other; "
                                 "name two files")


# -- JSON Lines: one finished record a line, so a killed run keeps what it finished --------------
def jsonl_path(json_path: str | os.PathLike) -> Path:
    """The JSON Lines file beside a JSON output: ``OUT.json`` -> ``OUT.jsonl``, ``OUT`` (any
    other name) -> ``OUT.jsonl`` appended (``x.txt`` -> ``x.txt.jsonl``)."""
    p = Path(json_path)
    return p.with_suffix(".jsonl") if p.suffix == ".json" else p.with_name(p.name + ".jsonl")


class JsonLines:
    """Appends one JSON value a line to ``path``, each line in one unbuffered write (a process
    killed with SIGKILL keeps every line it finished). The file is created, replacing an older one, at the first
    :meth:`append`: a command that fails before its first record leaves the old file as it was.
    With ``path`` ``None`` the records are dropped (a command run without an output file)."""

    def __init__(self, path: str | os.PathLike | None):
        self.path = None if path is None else Path(path)
        self._file = None

    def append(self, record: Any) -> None:
        if self.path is None:
            return
        if self._file is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "wb", buffering=0)  # noqa: SIM115 (kept open across appends)
        self._file.write((json.dumps(record, allow_nan=True) + "\n").encode("utf-8"))  # one write: a whole line or none

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> JsonLines:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# -- reading arrays: numbers only, never a pickle, never more than the file holds ---------------
def read_npz(path: str | os.PathLike, max_bytes: int) -> dict[str, np.ndarray]:
    """Every array of a ``.npz`` file (numpy's zip of ``.npy`` members), read without ever
    unpickling: an array of Python objects, or of anything but booleans and numbers, is refused;
    so is an array whose header declares more data than its member holds, or a file whose arrays
    add up to more than ``max_bytes``. Raises ``ValueError`` with the reason (the caller names
    the file); ``OSError`` if it cannot be read."""
    try:
        zf = zipfile.ZipFile(path)
    except zipfile.BadZipFile:
        raise ValueError("it is not a zip of arrays (.npz): the file is truncated or of another kind") from None
    arrays: dict[str, np.ndarray] = {}
    with zf:
        infos = zf.infolist()
        total = sum(i.file_size for i in infos)
        if total > max_bytes:
            raise ValueError(f"its arrays take {total / 1e6:.0f} MB, more than the {max_bytes / 1e6:.0f} MB allowed")
        for info in infos:
            name = info.filename
            if not name.endswith(".npy") or "/" in name:
                raise ValueError(f"member '{name}' is not an array (.npy)")
            try:
                with zf.open(info) as f:
                    version = np.lib.format.read_magic(f)
                    if version == (1, 0):
                        shape, _fortran, dtype = np.lib.format.read_array_header_1_0(f)
                    elif version == (2, 0):
                        shape, _fortran, dtype = np.lib.format.read_array_header_2_0(f)
                    else:
                        raise ValueError(f"array '{name[:-4]}' has .npy format version {version}; only 1.0 and 2.0 are read")
                    if dtype.hasobject:
                        raise ValueError(f"array '{name[:-4]}' holds Python objects (a pickle), which petswarm never loads")
                    if dtype.kind not in "biuf":
                        raise ValueError(f"array '{name[:-4]}' holds {dtype} data, not numbers")
                    declared = math.prod(shape) * dtype.itemsize
                    if declared > info.file_size:
                        raise ValueError(f"array '{name[:-4]}' declares shape {shape} ({declared} bytes) "
                                         f"but holds {info.file_size} bytes")
                with zf.open(info) as f:
                    arrays[name[:-4]] = np.lib.format.read_array(f, allow_pickle=False)
            except (zipfile.BadZipFile, EOFError, KeyError) as exc:
                raise ValueError(f"array '{name[:-4]}' is damaged ({type(exc).__name__}: {exc})") from None
    return arrays


# -- signals: SIGTERM and SIGHUP end a command as Ctrl-C does, through every cleanup ------------
class Terminated(SystemExit):
    """Raised in the main thread on SIGTERM or SIGHUP (:func:`exit_cleanly_on_signals`): it
    unwinds like Ctrl-C, so :func:`write_atomic` removes its temporary file, ``finally`` blocks
    close worker processes and files; its exit status is 128 + the signal's number. (Its only
    argument is the signal, so that code re-raising it as ``type(exc)(*exc.args)``, as SimPy does
    for an exception inside a process, raises the same.)"""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum
        self.code = 128 + signum

    def __str__(self) -> str:
        return f"terminated by {signal.Signals(self.signum).name}"


# the exception of the last signal (exit_cleanly_on_signals): a signal that arrives while a C
# library runs Python code for it (pymunk's cffi callbacks: a contact's begin, a space freed when an
# episode's world is dropped) has its exception swallowed there, so the loops that run episodes raise
# it again at their next step (raise_pending_signal); Python reports the swallowed one through
# sys.unraisablehook ("Exception ignored from cffi callback", a traceback), which _quiet_unraisable
# leaves out: the command's one line comes when it is raised again
_PENDING: list[BaseException] = []


def _quiet_unraisable(previous: Callable[[Any], None]) -> Callable[[Any], None]:
    """An unraisable-exception hook that drops the pending signal's exception and hands any other to ``previous``."""
    def hook(unraisable) -> None:
        if _PENDING and unraisable.exc_value is _PENDING[0]:
            return
        previous(unraisable)
    return hook


def _raise_terminated(signum, frame) -> None:
    _PENDING[:] = [Terminated(signum)]
    raise _PENDING[0]


def _raise_interrupt(signum, frame) -> None:
    _PENDING[:] = [KeyboardInterrupt()]
    raise _PENDING[0]


def raise_pending_signal() -> None:
    """Raise again the exception of a signal that arrived inside the command
    (:func:`exit_cleanly_on_signals`): a no-op unless one did; a signal swallowed by a C callback
    ends the command here instead of being lost. Called once per step by the episode loops."""
    if _PENDING:
        raise _PENDING[0]


@contextlib.contextmanager
def exit_cleanly_on_signals() -> Iterator[None]:
    """While the block runs, SIGTERM and SIGHUP raise :class:`Terminated` and SIGINT
    ``KeyboardInterrupt`` (the ``petswarm`` command runs in it), each also kept for
    :func:`raise_pending_signal`; the previous handlers come back after it. Outside the main thread it changes nothing (Python allows handlers only there)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.signal(sig, _raise_terminated) for sig in (signal.SIGTERM, signal.SIGHUP)}
    previous[signal.SIGINT] = signal.signal(signal.SIGINT, _raise_interrupt)
    unraisable_hook, sys.unraisablehook = sys.unraisablehook, _quiet_unraisable(sys.unraisablehook)
    try:
        yield
    finally:
        _PENDING.clear()
        sys.unraisablehook = unraisable_hook
        for sig, handler in previous.items():
            signal.signal(sig, handler)
