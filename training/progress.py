"""Progress of a training run: on a terminal a progress line redrawn in place (SB3's rich bar, or
:class:`LineProgress` for the RLlib back end); when the output is not a terminal a log line every
``every_s`` seconds instead (stdlib :mod:`logging`, logger ``petswarm.train``, level INFO), since a
redrawn line in a file or a CI log is nothing or a heap of control characters."""

from __future__ import annotations

import logging
import sys
import time

LOG = logging.getLogger("petswarm.train")
EVERY_S = 30.0  # seconds between two progress log lines


def wants_bar(progress: bool) -> bool:
    """Whether to draw a progress bar: asked for, and stderr is a terminal."""
    return progress and sys.stderr.isatty()


def progress_text(steps: int, total: int, rate: float) -> str:
    left = max(total - steps, 0)
    eta = f", about {left / rate / 60:.0f} min left" if rate > 0 and left else ""
    return f"trained {steps:,} of {total:,} agent-steps ({100 * steps / max(total, 1):.0f} %), {rate:,.0f} steps/s{eta}"


class LineProgress:
    """The RLlib back end's progress: :meth:`update` after each training iteration redraws one line
    on a terminal, or logs one every ``every_s`` seconds otherwise; :meth:`close` ends it."""

    def __init__(self, total: int, every_s: float = EVERY_S):
        self.total, self.every_s = total, every_s
        self.tty = sys.stderr.isatty()
        self.last = time.monotonic()
        self.text = ""

    def update(self, steps: int, rate: float) -> None:
        self.text = progress_text(steps, self.total, rate)
        if self.tty:
            print(f"\r{self.text}", end="", file=sys.stderr, flush=True)
        elif time.monotonic() - self.last >= self.every_s:
            self.last = time.monotonic()
            LOG.info(self.text)

    def close(self) -> None:
        if self.tty:
            print(file=sys.stderr)
        elif self.text:
            LOG.info(self.text)


def log_progress_callback(total: int, every_s: float = EVERY_S):
    """An SB3 callback that logs the progress every ``every_s`` seconds and once at the end (for a
    run whose output is not a terminal; SB3's own bar draws on a terminal)."""
    from stable_baselines3.common.callbacks import BaseCallback

    class LogProgress(BaseCallback):
        def _on_training_start(self) -> None:
            self.t0 = self.last = time.monotonic()
            self.start_steps = self.num_timesteps

        def _text(self) -> str:
            rate = (self.num_timesteps - self.start_steps) / max(time.monotonic() - self.t0, 1e-9)
            return progress_text(self.num_timesteps, total, rate)

        def _on_step(self) -> bool:
            if time.monotonic() - self.last >= every_s:
                self.last = time.monotonic()
                LOG.info(self._text())
            return True

        def _on_training_end(self) -> None:
            LOG.info(self._text())

    return LogProgress()
