"""Per-episode metrics: the experimenter's view, computed from ground truth (never observed).

``formation_rmse_m``: RMS over slaves and steps after organizing of the distance between a
slave's true position and its reference position (its reference neighbours' true positions plus
its offset rotated by the formation heading, the master's true heading).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class EpisodeMetrics:
    sq_error_sum: float = 0.0
    error_count: int = 0
    steps: int = 0
    organize_time_s: float = math.nan
    join_retries: int = 0
    error_trace: list[float] = field(default_factory=list)  # mean formation error per step (m)

    def add_step(self, errors_m: list[float]) -> None:
        self.steps += 1
        if errors_m:
            self.sq_error_sum += sum(e * e for e in errors_m)
            self.error_count += len(errors_m)
            self.error_trace.append(sum(errors_m) / len(errors_m))

    @property
    def formation_rmse_m(self) -> float:
        return math.sqrt(self.sq_error_sum / self.error_count) if self.error_count else math.nan
