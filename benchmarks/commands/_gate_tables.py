"""The regression gate's printed tables (a gate run's verdicts and the calibration), and the
consoles and progress bars the commands print on."""
from __future__ import annotations

from benchmarks.constants import CLOSED_FORM

__all__ = ["gate_table", "calibration_table", "wide_console", "progress_bar"]


def wide_console(width: int, *, soft_wrap: bool = False, quiet: bool = False):
    """A rich console on stdout, at least ``width`` wide where it is no terminal (logs and pipes:
    one table row per line; ``soft_wrap``: no line cut at all)."""
    from rich.console import Console

    console = Console(quiet=quiet)
    return console if console.is_terminal else Console(width=max(console.width, width), soft_wrap=soft_wrap,
                                                       quiet=quiet)


def progress_bar(args, label: str = "{task.description}", *, stderr: bool = True):
    """A transient rich progress bar (spinner, ``label``, bar, done/total, time), silent with ``--quiet``."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    return Progress(SpinnerColumn(), TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                    console=Console(stderr=stderr, quiet=args.quiet), transient=True)


def gate_table(report):
    """The verdict of every comparison of a :class:`benchmarks.gate.GateReport`, as a rich table."""
    from rich.markup import escape
    from rich.table import Table

    c0 = report.cases[0]
    table = Table(title=f"rtbench gate: {c0.width}x{c0.height}, {c0.spp} spp, seed {c0.seed}; alpha {report.alpha:g} "
                        f"for the run = {report.case_alpha:.3g} per comparison")
    for col in ("scene", "strategy", "reference", "verdict", "p-value", "failed levels", "relative bias +- se",
                "catches (global / 8x8 tile)", "where (strongest evidence)"):
        table.add_column(col, overflow="fold")
    for c in report.cases:
        r = c.result
        verdict = {"pass": "[green]pass[/]", "fail": "[bold red]FAIL[/]",
                   "undetermined": f"[yellow]undetermined[/] (needs ~{r.spp_needed} spp)"}[r.verdict]
        ref = (CLOSED_FORM if c.reference.source == CLOSED_FORM else
               f"{c.reference.variant} {c.reference.spp} spp" if c.reference.source == "store" else
               f"Mitsuba {c.reference.spp} spp")
        table.add_row(c.scene, c.strategy, ref, verdict, f"{r.p_value:.3g}", ", ".join(r.failed_levels) or "-",
                      f"{r.relative_bias:+.2%} +- {r.relative_bias_se:.2%}",
                      f"{_pct(r.min_detectable_bias)} / {_pct(r.min_detectable_tile_bias)}",
                      escape(c.where()) if c.failed else "-")
    return table


def _pct(v: float) -> str:
    """A relative bias as a percentage; '-' where the level tests nothing."""
    return f"{v:.2%}" if v == v else "-"


def calibration_table(rows, *, alpha: float, pairs: bool = False):
    """The false-alarm table of :func:`benchmarks.gate.calibrate`'s rows, as a rich table
    (``pairs``: of ``rtbench compare``'s verdict on pairs of renders)."""
    from rich.table import Table

    what = "rtbench compare's verdicts on pairs of renders of this build" if pairs else "verdicts on unbiased renders"
    table = Table(title=f"rtbench gate --calibrate: {what}, alpha {alpha:g} per comparison")
    for col in ("scene", "strategy", "spp", "seeds", "pass", "fail", "undetermined", "false alarms (95% CI)",
                "consistent", "undetermined needs ~spp", "catches (global)"):
        table.add_column(col)
    for r in rows:
        table.add_row(r.scene, r.strategy, str(r.spp), str(r.seeds), str(r.passed), str(r.failed), str(r.undetermined),
                      f"{r.false_alarm_rate:.3f} ({r.ci_low:.3f}-{r.ci_high:.3f})",
                      "[green]yes[/]" if r.consistent else "[bold red]NO[/]",
                      "-" if r.spp_needed is None else str(r.spp_needed), _pct(r.min_detectable_bias))
    return table
