"""``sensor_mapping``: seed 001 §VI.A — the sensor mapper maps the software robot Rity's sensors
(the virtual robot, Table IV: 8 ``DISTANCE`` sensors at radius 0.15 m and 180, 135, 90, 45, 0,
315, 270, 225°) onto the body Mybot (the physical robot, Table III: 6 ``DISTANCE`` sensors at
radius 0.15 m and 180, 135, 90, 45, 0, 270°), through :mod:`petswarm_env.mapping` (type
comparator, then location comparator on angles only, §VI.A), and must give Table V: physical 1–5
→ virtual 1–5, physical 6 → virtual 7, type and location valid on every row.

The rows compare the table the mapper builds with Table V as the paper prints it
(:data:`petswarm_env.mapping.TABLE_V`, written as data), row by row; nothing is fitted (basis
``validated``). The JSON carries the built table as ``data.table``, a list of ``{physical,
virtual, valid_type, valid_location}``, beside the paper's (``data.paper_table``).
"""

from __future__ import annotations

import math

from petswarm.experiments.results import Experiment, ExperimentResult, Progress, Row
from petswarm_env.config import Config
from petswarm_env.mapping import MYBOT, RITY, TABLE_V, SensorRow, seed001_sensor_mapper

BASIS = "validated"  # computed from the paper's registrations; no parameter is fitted


def mapping_rows(built: tuple[SensorRow, ...], paper: tuple[SensorRow, ...] = TABLE_V) -> list[Row]:
    """Table V (``paper``) against the ``built`` table: one row per physical sensor of the paper
    (its mapped virtual sensor; a physical sensor the built table leaves unmapped or lacks gives
    n/a and fails), then the counts of physical sensors in the table, of valid types and of valid
    locations (Table V: all six)."""
    by_physical = {r.physical: r for r in built}
    rows = []
    for p in paper:
        got = by_physical.get(p.physical)
        sim = math.nan if got is None or got.virtual is None else float(got.virtual)
        rows.append(Row.within(f"physical {p.physical} → virtual (Table V)", float(p.virtual), sim, 0.0, basis=BASIS))
    for metric, paper_n, sim_n in (
        ("physical sensors in the table", len(paper), len(built)),
        ("rows with a valid type", sum(r.valid_type for r in paper), sum(r.valid_type for r in built)),
        ("rows with a valid location", sum(r.valid_location for r in paper), sum(r.valid_location for r in built)),
    ):
        rows.append(Row.within(metric, float(paper_n), float(sim_n), 0.0, basis=BASIS))
    return rows


def _registered(sensors) -> list[dict]:
    return [{"id": s.id, "type": s.type, "radius_m": s.location.radius_m, "angle_deg": s.location.angle_deg}
            for s in sensors]


def sensor_mapping(cfg: Config, seed: int, quick: bool, progress: Progress) -> ExperimentResult:
    """Seed 001 §VI.A: Rity onto Mybot through the sensor mapper; rows against Table V. Pure and
    deterministic: ``cfg``, ``seed`` and ``quick`` do not enter."""
    mapper = seed001_sensor_mapper()
    deliveries = mapper.deliver({s.id: 1.0 for s in MYBOT.sensors})  # every physical sensor reading
    data = {
        "table": mapper.table_dicts(),
        "paper_table": [r.as_dict() for r in TABLE_V],
        "virtual": _registered(RITY.sensors),
        "physical": _registered(MYBOT.sensors),
        "virtual_without_source": [v for v, d in deliveries.items() if not d.present],
    }
    progress(1, 1)
    angles = {s.id: s.location.angle_deg for s in RITY.sensors}
    unmapped = ", ".join(f"{v} ({angles[v]:g}°)" for v in data["virtual_without_source"])
    note = f"Rity's virtual sensors without a physical match on Mybot deliver nothing (presence 0): {unmapped or 'none'}"
    return ExperimentResult(mapping_rows(mapper.table), data, note=note)


EXPERIMENT = Experiment("sensor_mapping", "Sensor mapping table, Rity onto Mybot (seed 001 §VI.A, Tables III–V)",
                        sensor_mapping)
