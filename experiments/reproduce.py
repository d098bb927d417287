"""``petswarm reproduce``: run the registry's experiments, print paper vs simulation (each row with
its basis: calibrated or validated), write the JSON and the HTML page, and say
whether every row is within its tolerance and how many of each basis are.

    petswarm reproduce [--only NAME,...] [--quick] [--json OUT] [--report OUT.html] [--check] [--seed S]
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterable
from typing import Any

from petswarm.experiments.registry import EXPERIMENTS, basis_summary, check_passed, results_json, run_experiments
from petswarm.experiments.results import ExperimentResult, Progress, format_figure
from petswarm_env.config import Config
from petswarm_env.files import write_json_atomic


def reproduce(cfg: Config, names: list[str], seed: int, quick: bool, json_out: str | None = None,
              report_out: str | None = None, check: bool = False, command: str = "petswarm reproduce") -> int:
    """Run ``names`` with progress bars, print the table and the verdict, write ``json_out`` and
    ``report_out`` when given; the exit status: 1 with ``check`` when a row fails, else 0."""
    results = reproduce_results(cfg, names, seed, quick, json_out, report_out, command)
    return 1 if check and not check_passed(results) else 0


def reproduce_results(cfg: Config, names: list[str], seed: int, quick: bool, json_out: str | None = None,
                      report_out: str | None = None, command: str = "petswarm reproduce") -> dict[str, ExperimentResult]:
    """:func:`reproduce` without the exit status: the results, after printing and writing them."""
    t0 = time.perf_counter()
    with ProgressBars(names) as progress_for:
        results = run_experiments(names, cfg, seed, quick, progress_for)
    wall = time.perf_counter() - t0
    print_table(results)
    passed = check_passed(results)
    print(f"{'PASS' if passed else 'FAIL'}: {sum(r.ok for r in results.values())}/{len(results)} experiments within "
          f"tolerance; rows within tolerance by basis: {basis_line(results)}; wall time {wall:.1f} s")
    if json_out:
        write_json_atomic(json_out, results_json(results, seed, quick))
        print(f"wrote {json_out}")
    if report_out:
        from petswarm.experiments.report import write_reproduce_report

        write_reproduce_report(results, report_out, command)
        print(f"wrote {report_out}")
    return results


def basis_line(results: dict[str, ExperimentResult]) -> str:
    """``calibrated 9/9, validated 18/20``: rows within tolerance per basis."""
    return ", ".join(f"{b} {c['ok']}/{c['rows']}" for b, c in basis_summary(results).items())


HEAD = ("experiment", "metric", "basis", "paper", "sim", "tolerance", "ok")


def table_lines(results: dict[str, ExperimentResult]) -> list[tuple[str, ...]]:
    """The side-by-side table as text cells (:data:`HEAD`): experiment, metric, basis, paper, sim,
    tolerance, ok; then a ``fit:`` line (what was calibrated, and how) and a ``note:`` line."""
    lines = []
    for name, res in results.items():
        if not res.available:
            lines.append((name, res.note or "not available yet", "", "", "", "", "FAIL"))
            continue
        for i, r in enumerate(res.rows):
            lines.append((name if i == 0 else "", r.metric, r.basis, format_figure(r.paper), format_figure(r.sim),
                          "±" + format_figure(r.tolerance), "ok" if r.ok else "FAIL"))
        for label, text in (("fit", res.calibration), ("note", res.note)):
            if text:
                lines.append(("", f"{label}: {text}", "", "", "", "", ""))
    return lines


def markdown_table(results: dict[str, ExperimentResult]) -> str:
    """docs/reproduce.md's table (GitHub markdown): a row per figure with its basis; a failing
    row's ok in bold."""
    out = ["| experiment | metric | basis | paper | sim | tolerance | ok |", "|---|---|---|---|---|---|---|"]
    for name, res in results.items():
        title = EXPERIMENTS[name].title if name in EXPERIMENTS else name
        label = f"{name} ({title.rsplit('(', 1)[1]}" if "(" in title else name
        if not res.available:
            out.append(f"| {label} | {res.note or 'not available yet'} |  |  |  |  | **FAIL** |")
        for i, r in enumerate(res.rows):
            out.append(f"| {label if i == 0 else ''} | {r.metric} | {r.basis} | {format_figure(r.paper)} | {format_figure(r.sim)} "
                       f"| ±{format_figure(r.tolerance)} | {'ok' if r.ok else '**FAIL**'} |")
    return "\n".join(out)


def print_table(results: dict[str, ExperimentResult]) -> None:
    """Print paper vs sim (a rich table when rich is installed, plain columns otherwise)."""
    lines = table_lines(results)
    n_left = 3  # experiment, metric, basis: left-aligned
    try:
        from rich.console import Console
        from rich.table import Table
    except ImportError:
        widths = [max(len(row[i]) for row in [HEAD, *lines]) for i in range(len(HEAD))]
        for row in [HEAD, *lines]:
            print("  ".join(c.ljust(w) if i < n_left else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths))))
        return
    table = Table(title="petswarm reproduce: paper vs simulation")
    for i, h in enumerate(HEAD):
        table.add_column(h, justify="left" if i < n_left else "right")
    for row in lines:
        style = "red" if row[-1] == "FAIL" else None
        table.add_row(*row, style=style)
    Console(width=max(120, Console().width)).print(table)


class ProgressBars:
    """Context manager giving ``progress_for(name)`` callbacks that drive one bar per experiment
    (rich on stderr; without rich, a line per finished experiment)."""

    def __init__(self, names: Iterable[str]):
        self.names = list(names)
        self._progress = None
        self._tasks: dict[str, Any] = {}

    def __enter__(self) -> Callable[[str], Progress]:
        try:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
        except ImportError:
            return self._plain
        self._progress = Progress(TextColumn("{task.description:<14}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                                  console=Console(stderr=True), transient=False)
        self._progress.__enter__()
        self._tasks = {n: self._progress.add_task(n, total=None) for n in self.names}
        return self._rich

    def _rich(self, name: str) -> Progress:
        task = self._tasks[name]

        def update(done: int, total: int) -> None:
            self._progress.update(task, completed=done, total=total)

        return update

    def _plain(self, name: str) -> Progress:
        def update(done: int, total: int) -> None:
            if done >= total:
                print(f"{name}: done", file=sys.stderr)

        return update

    def __exit__(self, *exc) -> None:
        if self._progress is not None:
            self._progress.__exit__(*exc)
