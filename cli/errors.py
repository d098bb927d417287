"""Every error a user can cause, as one line: the ``petswarm`` command (cli/main.py) and the
experiments' own programs (``python -m petswarm.experiments.NAME``) print it on stderr and exit 2,
never a traceback; Ctrl-C exits 130, SIGTERM/SIGHUP 128 + the signal, after every temporary file is
removed (:func:`petswarm_env.files.exit_cleanly_on_signals`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from petswarm_env.config import ConfigError
from petswarm_env.files import Terminated, exit_cleanly_on_signals

USER_ERRORS = (ConfigError, ValueError, RuntimeError, OSError)  # what bad input, a bad config or a bad path raise


class OneLineParser(argparse.ArgumentParser):
    """An argparse parser whose errors (an unknown option, a bad value) are one line ``<name>: error: ...`` with exit
    status 2, not a usage block; ``name`` is the program's (``prog`` when not set)."""

    name: str | None = None

    def error(self, message: str):
        self.exit(2, f"{self.name or self.prog}: error: {message}\n")


def one_line(exc: BaseException) -> str:
    """The error's text on one line (an OS error names its file)."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    if isinstance(exc, OSError) and exc.filename is not None and str(exc.filename) not in text:
        text = f"{text} ('{exc.filename}')"
    return text


def run_program(prog: str, main: Callable[[], int | None]) -> int:
    """Run ``main`` as the program ``prog``: its return value (``None``: 0) is the exit status; a user's
    error is one line ``<prog>: error: ...`` and status 2."""
    try:
        with exit_cleanly_on_signals():
            return main() or 0
    except USER_ERRORS as exc:
        print(f"{prog}: error: {one_line(exc)}", file=sys.stderr)
        return 2
    except Terminated as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return exc.code
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
