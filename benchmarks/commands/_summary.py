"""The tables ``rtbench curves`` and ``rtbench run`` print (rich): the per-curve summary table
(one row per scene and size, one column per curve: slope under ``--metric``, efficiency and
throughput relative to Mitsuba) and the run's headline, each followed by the seed comparison.

>>> summary_table([]).title
'rtbench summary (metric: relMSE)'
"""
from __future__ import annotations

import math

from benchmarks.constants import SEED_SCENE, SEED_SIZE, SEED_SPP, STRATEGIES
from benchmarks.metrics import DEFAULT_METRIC, SPECS, view
from benchmarks.sweep import finite
from benchmarks.text import terminal


def _f(v, digits=2):
    """A number in a cell: fixed point, or scientific when very large or small; '-' for none.

    >>> _f(0.5), _f(12345.0), _f(None)
    ('0.50', '1.2e+04', '-')
    """
    v = finite(v)
    if v is None:
        return "-"
    return f"{v:.1e}" if v != 0 and (abs(v) >= 1e4 or abs(v) < 1e-2) else f"{v:.{digits}f}"


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


def _cell(r):
    """Line 1: slope, or the failed bias test; line 2: ratios to Mitsuba (Mitsuba's own: its samples/s)."""
    from rich.text import Text

    t = Text()
    if r.get("bias_verdict") == "fail" or r.get("bias_significant") is True:
        rel = finite(r.get("relative_bias"))
        t.append("fail" + (f" {100 * rel:+.1f}%" if rel is not None else ""), style="bold red")
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
    """A ``rich.table.Table`` of ``summary.json``'s rows under ``metric`` (:func:`benchmarks.metrics.view`)."""
    from rich.table import Table
    from rich.text import Text

    spec = SPECS[metric]
    rows = [view(r, metric) for r in rows]
    expected = (f" ({spec.unbiased_slope:+.2f} = unbiased Monte Carlo)" if spec.unbiased_slope is not None
                else " (no theoretical value)")
    # ours before Mitsuba, our strategies in their order
    curves = sorted(dict.fromkeys((r.get("renderer"), r.get("strategy")) for r in rows),
                    key=lambda c: (c[0] != "ours", STRATEGIES.index(c[1]) if c[1] in STRATEGIES else 9, str(c[1])))
    sections = dict.fromkeys((r.get("scene"), r.get("width"), r.get("height")) for r in rows)
    table = Table(title=f"{title} (metric: {spec.label})", show_lines=True, caption_justify="left",
                  caption=f"line 1: slope of {spec.label} vs spp{expected}, or fail with the relative bias where the "
                          "bias test fails, or (undetermined) where the estimator is too heavy-tailed at this budget for "
                          f"a verdict; line 2: efficiency 1/({spec.label}*s) | samples/s, both relative to Mitsuba "
                          "path (Mitsuba: its samples/s); 'biased' or 'undetermined' instead of an efficiency where "
                          "the bias test found a bias or could not decide")
    table.add_column("scene", no_wrap=True)
    for renderer, strategy in curves:
        name = strategy if renderer == "ours" else f"{'Mitsuba' if renderer == 'mitsuba' else renderer} {strategy}"
        table.add_column(Text(terminal(name)), no_wrap=True, justify="right")
    by = {(r.get("scene"), r.get("width"), r.get("height"), r.get("renderer"), r.get("strategy")): r for r in rows}
    for scene, w, h in sections:
        cells = [Text(terminal(f"{scene}\n{w}x{h}"))]  # store fields: no terminal escapes
        cells += [Text("") if by.get((scene, w, h, *c)) is None else _cell(by[(scene, w, h, *c)]) for c in curves]
        table.add_row(*cells)
    return table


def seed_comparison_line(records) -> str | None:
    """The seed's comparison as one sentence, when the store holds it."""
    from reports.curves import seed_comparison

    cmp = seed_comparison(records)
    if cmp is None or not math.isfinite(cmp.get("target_rmse", math.nan)):
        return None
    where = (f"light reaches it at ~{_f(cmp['light_spp'], 3)} spp ({cmp['method']})"
             if math.isfinite(cmp.get("light_spp", math.nan)) else f"light never does ({cmp['method']})")
    return (f"seed comparison ({SEED_SCENE} {SEED_SIZE}x{SEED_SIZE}): uniform at {SEED_SPP} spp has {cmp['label']} "
            f"{_f(cmp['target_rmse'], 3)}; {where}")


def print_summary(store, *, console, metric: str = DEFAULT_METRIC) -> None:
    """Print the summary table of a results store under ``metric`` and the seed comparison line."""
    from benchmarks.store import read_records, read_summary_rows

    rows = read_summary_rows(store)
    if not rows:
        console.print(f"{store}: no summary rows yet")
        return
    console.print(summary_table(rows, metric=metric))
    line = seed_comparison_line(read_records(store))
    if line:
        console.print(line, highlight=False)


def print_headline(store, *, console) -> None:
    """Print the run's answer (the report's first table, :mod:`reports.headline`) and the seed comparison line."""
    from benchmarks.store import read_records
    from benchmarks.text import text_table
    from reports.headline import headline_cells, headline_entries, headline_header
    from reports.store import load_store

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
