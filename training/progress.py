"""Progress of a training run when its output is not a terminal: a log line every
``every_s`` seconds (stdlib :mod:`logging`, logger ``petswarm.train``, level INFO) instead of the
progress bar, which draws only on a terminal (rich redraws one line; in a file or a CI log it
would be nothing or a heap of control characters)."""

from __future__ import annotations

import logging
import sys
import time

from stable_baselines3.common.callbacks import BaseCallback

LOG = logging.getLogger("petswarm.train")


def wants_bar(progress: bool) -> bool:
    """Whether to draw SB3's progress bar: asked for, and stderr is a terminal."""
    return progress and sys.stderr.isatty()


class LogProgress(BaseCallback):
    """Logs ``trained N of M agent-steps (P %), R steps/s, about T left`` every ``every_s``
    seconds of wall time, and once at the end."""

    def __init__(self, total: int, every_s: float = 30.0):
        super().__init__()
        self.total, self.every_s = total, every_s

    def _on_training_start(self) -> None:
        self.t0 = self.last = time.monotonic()
        self.start_steps = self.num_timesteps

    def _line(self) -> str:
        done = self.num_timesteps - self.start_steps
        rate = done / max(time.monotonic() - self.t0, 1e-9)
        left = max(self.total - self.num_timesteps, 0)
        eta = f", about {left / rate / 60:.0f} min left" if rate > 0 and left else ""
        return (f"trained {self.num_timesteps:,} of {self.total:,} agent-steps ({100 * self.num_timesteps / max(self.total, 1):.0f} %), "
                f"{rate:,.0f} steps/s{eta}")

    def _on_step(self) -> bool:
        now = time.monotonic()
        if now - self.last >= self.every_s:
            self.last = now
            LOG.info(self._line())
        return True

    def _on_training_end(self) -> None:
        LOG.info(self._line())
