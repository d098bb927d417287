"""What a paper experiment returns: rows of *paper figure vs simulated figure*, each with its
tolerance and its basis, and the data behind the report's plots.

An experiment is a function ``(cfg, seed, quick, progress) -> ExperimentResult`` described by an
:class:`Experiment` (its name, part of the ``petswarm reproduce --only`` interface, and title);
``progress(done, total)`` reports how far it got. An experiment whose simulation is not built yet
raises :class:`NotAvailable`: it shows up as "not available yet", has no rows (never a made-up
number) and makes the check fail.

Every row says what it tests (:data:`BASES`):

* ``calibrated``: a parameter of the simulation was fitted to this very figure, so agreement is
  the fit, not a confirmation;
* ``validated``: nothing was fitted to it; the simulation predicts it (a held-out point of a fit,
  or a figure no parameter was tuned to).

A row's paper figure is one the paper publishes (or states, like "rises with the slave count"),
never one read between its figures.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

Progress = Callable[[int, int], None]  # progress(done, total)

RMSE_TOLERANCE_REL = 0.20  # chosen: RMSEs within ±20 % of the paper


BASES = ("calibrated", "validated")  # what a row tests (module docstring)


@dataclass(frozen=True)
class Row:
    """One paper figure against the simulated one. ``ok``: ``|sim − paper| <= tolerance`` (or the
    experiment's own one-sided test); ``basis``: one of :data:`BASES`."""

    metric: str
    paper: float
    sim: float
    tolerance: float
    ok: bool
    basis: str

    def __post_init__(self) -> None:
        if self.basis not in BASES:
            raise ValueError(f"row '{self.metric}': basis '{self.basis}' is not one of {', '.join(BASES)}")

    @classmethod
    def within(cls, metric: str, paper: float, sim: float, tolerance: float, *, basis: str) -> Row:
        sim = float(sim)
        ok = math.isfinite(sim) and abs(sim - paper) <= tolerance + 1e-12
        return cls(metric, float(paper), sim, float(tolerance), bool(ok), basis)

    def to_json(self) -> dict[str, Any]:
        return {"metric": self.metric, "paper": self.paper, "sim": self.sim, "tolerance": self.tolerance, "ok": self.ok,
                "basis": self.basis}


@dataclass
class ExperimentResult:
    rows: list[Row]
    data: dict[str, Any] = field(default_factory=dict)  # JSON-ready figures for the report
    available: bool = True
    note: str = ""
    wall_s: float = 0.0
    calibration: str = ""  # what was fitted to which rows, and the command that fits it

    @property
    def ok(self) -> bool:
        """Available, at least one row, and every row within its tolerance."""
        return self.available and bool(self.rows) and all(r.ok for r in self.rows)


class NotAvailable(Exception):
    """The simulation an experiment needs is not built yet (the message says what is missing)."""


@dataclass(frozen=True)
class Experiment:
    name: str
    title: str
    run: Callable[..., ExperimentResult]


def format_figure(v: float | None, digits: int = 3) -> str:
    """``digits`` decimals without trailing zeros (7.898, 0.6, 30); n/a for a missing or
    non-finite value."""
    if v is None or not math.isfinite(v):
        return "n/a"
    text = f"{v:.{digits}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text
