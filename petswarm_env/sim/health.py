"""One robot's hardware health: its active faults and whether each part works (:mod:`.faults` says
what each fault kind switches off; seed 003: robots fail and are replaced).

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode): the flags are
typed (``health.pxd``), so that what reads them for every frame and reading — a station's radio
(middleware/station.py), the AHRS (sim/sensors.py), the self-diagnosis (middleware/diagnosis.py), the
command loops (step_kernel.py) — reads them by C reads.
"""

from __future__ import annotations

import cython

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

KINDS = ("dead", "radio_silent", "ir", "ultrasonic", "ahrs", "battery")  # = config.FAULT_KINDS
POWER_KINDS = ("dead", "battery")  # the robot is off


@cython.cclass
class FaultState:
    """One robot's active faults and the health of each part (its typed attributes: ``health.pxd``)."""

    # ``active``: the fault kinds now on; the cached health flags (read per frame and per step), recomputed by set:
    # ``powered``, ``radio_ok``, ``ir_ok``, ``ultrasonic_ok``, ``ahrs_ok``

    def __init__(self) -> None:
        self.active = set()
        self.powered = self.radio_ok = self.ir_ok = self.ultrasonic_ok = self.ahrs_ok = True

    def set(self, kind: str, on: bool) -> None:
        """The one entry point: fault ``kind`` starts (``on``) or clears."""
        if kind not in KINDS:
            raise ValueError(f"unknown fault kind {kind!r}; one of {', '.join(KINDS)}")
        a = self.active
        if on:
            a.add(kind)
        else:
            a.discard(kind)
        self.powered = not (a & set(POWER_KINDS))
        self.radio_ok = self.powered and "radio_silent" not in a
        self.ir_ok = self.powered and "ir" not in a
        self.ultrasonic_ok = self.powered and "ultrasonic" not in a
        self.ahrs_ok = self.powered and "ahrs" not in a

    def __repr__(self) -> str:
        return f"FaultState(active={self.active!r})"
