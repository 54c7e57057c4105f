"""The one-screen summary table that ``rtbench curves`` and ``rtbench run`` print (rich).

One row per (scene, size); one column per curve (our strategies, then Mitsuba). A cell
shows the convergence slope under the chosen metric (``--metric``, default relMSE;
``BIASED`` when the bias test fires) on its first line and, on the second, efficiency
(under the same metric) and throughput relative to Mitsuba's ``path`` on the same scene
and size; a biased or undetermined estimator shows that word instead of an efficiency.
The seed's comparison (uniform vs light on ``cornell_box`` at 400x400) follows as one
line when the store holds it.

Examples
--------
>>> from benchmarks.commands._summary import summary_table
>>> summary_table([]).title
'rtbench summary (metric: relMSE)'
"""
from __future__ import annotations

import math

from benchmarks.constants import SEED_SCENE, SEED_SIZE, SEED_SPP, STRATEGIES
from benchmarks.sweep import finite
from benchmarks.metrics import DEFAULT_METRIC, SPECS, view
from benchmarks.text import terminal

__all__ = ["summary_table", "print_summary", "print_headline", "seed_comparison_line"]


def _f(v, digits=2):
    """A number in a cell: fixed point, or scientific when very large or small; '-' for none.

    >>> _f(0.5), _f(12345.0), _f(None)
    ('0.50', '1.2e+04', '-')
    """
    v = finite(v)
    if v is None:
        return "-"
    if v != 0 and (abs(v) >= 1e4 or abs(v) < 1e-2):
        return f"{v:.1e}"
    return f"{v:.{digits}f}"


def _si(v):
    """1234567 -> '1.2M'.

    >>> _si(1234567), _si(12)
    ('1.2M', '12')
    """
    v = finite(v)
    if v is None:
        return "-"
    for div, unit in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if abs(v) >= div:
            return f"{v / div:.1f}{unit}"
    return f"{v:.0f}"


def _curve_name(renderer, strategy):
    return strategy if renderer == "ours" else f"{'Mitsuba' if renderer == 'mitsuba' else renderer} {strategy}"


def _curve_order(curve) -> tuple:
    """Ours before Mitsuba, our strategies in :data:`benchmarks.constants.STRATEGIES` order."""
    renderer, strategy = curve
    return renderer != "ours", STRATEGIES.index(strategy) if strategy in STRATEGIES else 9, str(strategy)


def _cell(r):
    """Line 1: slope or BIASED z; line 2: ratios to Mitsuba (Mitsuba's own: its samples/s)."""
    from rich.text import Text

    t = Text()
    if r.get("bias_verdict") == "fail" or r.get("bias_significant") is True:
        rel = r.get("relative_bias")
        t.append("fail" + (f" {100 * rel:+.1f}%" if isinstance(rel, (int, float)) and math.isfinite(rel) else ""),
                 style="bold red")
    elif r.get("bias_verdict") == "undetermined":
        t.append(f"{_f(r.get('slope'))} (undetermined)", style="yellow")
    else:
        t.append(_f(r.get("slope")))
    if r.get("renderer") == "mitsuba":
        t.append(f"\n{_si(r.get('samples_per_second'))}/s")
    else:
        eff = r.get("cost_status") or _f(r.get("efficiency_vs_mitsuba"))
        t.append(f"\n{eff} | {_f(r.get('samples_per_second_vs_mitsuba'))}")
    return t


def summary_table(rows, *, title: str = "rtbench summary", metric: str = DEFAULT_METRIC):
    """A ``rich.table.Table`` of summary rows (``summary.json``'s ``rows``) under ``metric``.

    Parameters
    ----------
    rows : list of dict
    title : str, keyword-only
    metric : {'rmse', 'relmse', 'ssim', 'flip'}, keyword-only
        The error behind slopes and efficiency (:func:`benchmarks.metrics.view`).

    Returns
    -------
    rich.table.Table
    """
    from rich.table import Table
    from rich.text import Text

    spec = SPECS[metric]
    rows = [view(r, metric) for r in rows]
    title = f"{title} (metric: {spec.label})"
    expected = (f" ({spec.unbiased_slope:+.2f} = unbiased Monte Carlo)" if spec.unbiased_slope is not None
                else " (no theoretical value)")

    curves = []
    for r in rows:
        c = (r.get("renderer"), r.get("strategy"))
        if c not in curves:
            curves.append(c)
    curves.sort(key=_curve_order)
    sections = []
    for r in rows:
        s = (r.get("scene"), r.get("width"), r.get("height"))
        if s not in sections:
            sections.append(s)
    table = Table(title=title, show_lines=True, caption_justify="left",
                  caption=f"line 1: slope of {spec.label} vs spp{expected}, or fail with the relative bias where the "
                          "bias test fails, or (undetermined) where the estimator is too heavy-tailed at this budget for "
                          f"a verdict; line 2: efficiency 1/({spec.label}*s) | samples/s, both relative to Mitsuba "
                          "path (Mitsuba: its samples/s); 'biased' or 'undetermined' instead of an efficiency where "
                          "the bias test found a bias or could not decide")
    table.add_column("scene", no_wrap=True)
    for c in curves:
        table.add_column(Text(terminal(_curve_name(*c))), no_wrap=True, justify="right")
    by = {(r.get("scene"), r.get("width"), r.get("height"), r.get("renderer"), r.get("strategy")): r for r in rows}
    for scene, w, h in sections:
        cells = [Text(terminal(f"{scene}\n{w}x{h}"))]  # store fields: no terminal escapes
        for c in curves:
            r = by.get((scene, w, h, *c))
            cells.append(Text("") if r is None else _cell(r))
        table.add_row(*cells)
    return table


def seed_comparison_line(records) -> str | None:
    """The seed's comparison as one sentence, when the store holds it (needs ``reports``)."""
    try:
        from reports.curves import seed_comparison
    except ImportError:
        return None
    cmp = seed_comparison(records)
    if cmp is None or not math.isfinite(cmp.get("target_rmse", math.nan)):
        return None
    where = (f"light reaches it at ~{_f(cmp['light_spp'], 3)} spp ({cmp['method']})"
             if math.isfinite(cmp.get("light_spp", math.nan)) else f"light never does ({cmp['method']})")
    return (f"seed comparison ({SEED_SCENE} {SEED_SIZE}x{SEED_SIZE}): uniform at {SEED_SPP} spp has {cmp['label']} "
            f"{_f(cmp['target_rmse'], 3)}; {where}")


def print_summary(store, *, console=None, metric: str = DEFAULT_METRIC) -> None:
    """Print the summary table of a results store under ``metric`` (and the seed comparison line)."""
    from rich.console import Console

    from benchmarks.store import SUMMARY, read_json, read_records

    if console is None:
        console = Console()
        if not console.is_terminal:  # logs and pipes: wide enough for the table, no truncation
            console = Console(width=max(console.width, 120))
    summary = read_json(f"{store}/{SUMMARY}", default={}) or {}
    rows = summary.get("rows") or []
    if not rows:
        console.print(f"{store}: no summary rows yet")
        return
    console.print(summary_table(rows, metric=metric))
    line = seed_comparison_line(read_records(store))
    if line:
        console.print(line, highlight=False)


def print_headline(store, *, console=None) -> None:
    """Print the run's answer (the report's first table, :mod:`reports.headline`): per scene,
    ours against the reference, light sampling's bias, each strategy's noise relative to
    light sampling at equal spp and at equal time; then the seed's comparison line."""
    from rich.console import Console

    from benchmarks.store import read_records
    from benchmarks.text import text_table

    if console is None:
        console = Console(soft_wrap=True)
    try:
        from reports.headline import headline_cells, headline_entries, headline_header
        from reports.store import load_store
    except ImportError:
        print_summary(store, console=console)
        return
    entries = headline_entries(load_store(store))
    if not entries:
        console.print(f"{store}: no summary yet", highlight=False)
        return
    header = [h.replace(": equal spp / equal time", "") for h in headline_header(entries)]
    console.print("noise relative to light sampling, at equal spp / at equal time (x: times as noisy):",
                  highlight=False)
    console.print(text_table(header, headline_cells(entries, intervals=False)), highlight=False, markup=False)
    line = seed_comparison_line(read_records(store))
    if line:
        console.print(line, highlight=False, markup=False)
