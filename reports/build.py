"""Assemble the report: ``index.html`` (self-contained) and ``summary.md`` from a results store."""
from __future__ import annotations

import math
from pathlib import Path

from benchmarks.constants import SEED_SCENE, SEED_SIZE, SEED_SPP

from . import plots
from .curves import curve_label, seed_comparison
from .html import page_html
from .sections import PLOT_KINDS, Section, build_section, equal_time_text, seed_lines
from .store import Store, load_store
from .tables import COLUMNS, FORMULAS, facts_table, fmt, markdown_table, text_table

__all__ = ["build_report", "summary_table", "PLOT_KINDS"]


# ----------------------------------------------------------------------------------------- Markdown

def _markdown(store: Store, sections: list[Section], cmp, problems: list) -> str:
    out = [f"# rtbench report — {store.path.name}", "", "## Run facts", "",
           markdown_table(["fact", "value"], facts_table(store.meta, n_records=len(store.records),
                                                         n_raw=store.n_raw_records, records=store.records)), ""]
    for sec in sections:
        out += [f"## {sec.title}", ""]
        if sec.table:
            out += [markdown_table([h for h, _ in COLUMNS], sec.table), ""]
        else:
            out += ["summary.json holds no rows for this scene and size.", ""]
        et = equal_time_text(sec)
        if et:
            out += [et, ""]
        out += [f"- {n}" for n in sec.notes] + ([""] if sec.notes else [])
    lines, rows = seed_lines(cmp)
    out += [f"## Seed comparison: uniform vs light on {SEED_SCENE} {SEED_SIZE}x{SEED_SIZE}", ""] + lines + [""]
    if rows:
        out += [markdown_table(["spp", "uniform RMSE", "light RMSE"], rows), ""]
    out += ["## Metric definitions", ""] + [f"- **{k}**: {v}" for k, v in FORMULAS] + [""]
    if problems:
        out += ["## Problems found in the store", ""] + [f"- {p}" for p in problems] + [""]
    return "\n".join(out)


# ----------------------------------------------------------------------------------------- API

def _collect(store: Store):
    problems = list(store.problems)
    sections = [build_section(store, *k, problems=problems) for k in store.sections()]
    cmp = seed_comparison(store.records)
    seed_png = plots.seed_plot(cmp) if cmp is not None else None
    return sections, cmp, seed_png, problems


def build_report(store, *, out=None) -> Path:
    """Write ``index.html`` (self-contained) and ``summary.md`` for a results store.

    Parameters
    ----------
    store : str or Path
        The results store folder (see :func:`reports.store.load_store`).
    out : str or Path, optional
        Folder to write into (created if needed); default: the store folder.

    Returns
    -------
    Path
        The written ``index.html``.

    Raises
    ------
    ValueError
        If ``store`` is not a results store or ``out`` exists and is not a folder.

    Examples
    --------
    >>> from reports import build_report
    >>> build_report("reports/out/quick")  # doctest: +SKIP
    PosixPath('reports/out/quick/index.html')
    """
    st = load_store(store)
    dest = Path(out).expanduser() if out is not None else st.path
    if dest.exists() and not dest.is_dir():
        raise ValueError(f"report output {str(dest)!r} exists and is not a folder")
    sections, cmp, seed_png, problems = _collect(st)
    dest.mkdir(parents=True, exist_ok=True)
    page = dest / "index.html"
    tmp = dest / "index.html.tmp"
    tmp.write_text(page_html(st, sections, cmp, seed_png, problems), encoding="utf-8")
    tmp.replace(page)
    (dest / "summary.md").write_text(_markdown(st, sections, cmp, problems), encoding="utf-8")
    return page


def summary_table(store) -> str:
    """A one-screen plain-text summary of a store: per scene and strategy, the key figures.

    Parameters
    ----------
    store : str, Path or Store

    Returns
    -------
    str
    """
    st = store if isinstance(store, Store) else load_store(store)
    header = ["scene", "size", "strategy", "slope", "bias", "eff/Mitsuba", "t->target s", "samples/s", "/Mitsuba"]
    rows = []
    for scene, w, h in st.sections():
        for r in st.section_rows(scene, w, h):
            sig = r.get("bias_significant")
            rows.append([scene, f"{w}x{h}" if w and h else "?", curve_label(r["renderer"], r["strategy"]),
                         fmt(r.get("slope"), 3),
                         "BIASED" if sig is True else ("ok" if sig is False else
                                                       ("undetermined" if r.get("bias_verdict") == "undetermined"
                                                        else "-")),
                         fmt(r.get("efficiency_vs_mitsuba"), 3), fmt(r.get("time_to_target"), 3),
                         fmt(r.get("samples_per_second"), 3), fmt(r.get("samples_per_second_vs_mitsuba"), 3)])
    text = text_table(header, rows) if rows else "(summary.json holds no rows)"
    cmp = seed_comparison(st.records)
    if cmp is not None and math.isfinite(cmp["light_spp"]):
        text += (f"\nseed comparison ({SEED_SCENE} {SEED_SIZE}x{SEED_SIZE}): uniform at {SEED_SPP} spp has RMSE "
                 f"{fmt(cmp['target_rmse'], 3)}; light reaches it at ~{fmt(cmp['light_spp'], 3)} spp "
                 f"({cmp['method']})")
    return text
