"""Assemble the report from a results store: ``index.html`` (self-contained) and ``summary.md`` (html),
every plot as SVG and PDF (svg, pdf), tidy CSVs of the curves and the summary (csv)."""
from __future__ import annotations

import math
import shutil
import subprocess
import tempfile
from pathlib import Path

from reference_tracer.imageio import atomic_write

from benchmarks.constants import SEED_SCENE, SEED_SIZE, SEED_SPP
from benchmarks.files import slug
from benchmarks.metrics import DEFAULT_METRIC, SPECS, require_metric, view
from benchmarks.text import markdown, markdown_table, text_table

from . import plots
from .curves import curve_label, seed_comparison
from .html import page_html
from .sections import PLOT_KINDS, Section, build_section, equal_time_text, seed_lines
from .store import Store, load_store
from .headline import HEADLINE_NOTE, headline_cells, headline_entries, headline_header, percent_text
from .tables import FORMULAS, columns, facts_table, fmt, verdict_cell
from .tidy import curves_csv, headline_csv, summary_csv

__all__ = ["build_report", "write_report", "summary_table", "PLOT_KINDS", "FORMATS", "plot_file_stem"]

#: what :func:`write_report` can write.
FORMATS = ("html", "svg", "pdf", "csv")


# ----------------------------------------------------------------------------------------- Markdown

def _markdown(store: Store, sections: list[Section], cmp, problems: list, metric: str = DEFAULT_METRIC) -> str:
    out = [f"# rtbench report — {markdown(store.path.name)}", "",
           "How much noisier is each sampling strategy than light sampling, at equal samples and at equal time, "
           f"and does our tracer agree with Mitsuba 3? One error metric throughout: {SPECS[metric].label}. "
           "Efficiency and time to target are shown only where no bias was detected.", ""]
    entries = headline_entries(store)
    if entries:
        out += ["## The answer", "", markdown_table(headline_header(entries), headline_cells(entries)), "",
                markdown(HEADLINE_NOTE), ""]
    if cmp is not None:  # only where the store holds the seed's runs
        lines, rows = seed_lines(cmp)
        out += ([f"## Seed comparison: uniform vs light on {SEED_SCENE} {SEED_SIZE}x{SEED_SIZE}", ""]
                + [markdown(line) for line in lines] + [""])
        if rows:
            out += [markdown_table(["spp", f"uniform {cmp['label']}", f"light {cmp['label']}"], rows), ""]
    for sec in sections:
        out += [f"## {markdown(sec.title)}", ""]
        if sec.table:
            out += [markdown_table([h for h, _ in columns(sec.metric)], sec.table), ""]
        else:
            out += ["summary.json holds no rows for this scene and size.", ""]
        et = equal_time_text(sec)
        if et:
            out += [markdown(et), ""]
        out += [f"- {markdown(n)}" for n in sec.notes] + ([""] if sec.notes else [])
    out += ["## Run facts", "", markdown_table(["fact", "value"], facts_table(
        store.meta, n_records=len(store.records), n_raw=store.n_raw_records, records=store.records)), ""]
    out += ["## Metric definitions", ""] + [f"- **{k}**: {v}" for k, v in FORMULAS] + [""]
    if problems:
        out += ["## Problems found in the store", ""] + [f"- {markdown(p)}" for p in problems] + [""]
    return "\n".join(out)


# ----------------------------------------------------------------------------------------- API

def _collect(store: Store, metric: str):
    problems = list(store.problems)
    sections = [build_section(store, *k, problems=problems, metric=metric) for k in store.sections()]
    cmp = seed_comparison(store.records)
    seed_fig = plots.seed_plot(cmp) if cmp is not None else None
    return sections, cmp, seed_fig, problems


def plot_file_stem(sec: Section, kind: str) -> str:
    """File name (without extension) of a section's plot: scene, size and metric.

    ``time`` plots are named by the metric they show: ``<scene>_<W>x<H>_time-<metric>``. The
    scene name comes from the store (untrusted): it goes through :func:`benchmarks.files.slug`,
    so no name can climb out of ``plots/``.
    """
    size = f"{sec.width}x{sec.height}" if sec.width and sec.height else None
    what = f"time-{sec.metric}" if kind == "time" else kind
    return slug(sec.scene, size, what)


def _vector_files(dest: Path, sections: list[Section], seed_fig, fmt_: str) -> list[Path]:
    folder = dest / "plots"
    folder.mkdir(exist_ok=True)
    out = []
    figs = [(plot_file_stem(sec, kind), fig) for sec in sections for kind, fig in sec.figures.items()]
    if seed_fig is not None:
        figs.append((f"seed_{SEED_SCENE}_{SEED_SIZE}x{SEED_SIZE}_relmse", seed_fig))
    for stem, fig in figs:
        path = folder / f"{stem}.{fmt_}"
        atomic_write(path, plots.figure_bytes(fig, fmt_))
        out.append(path)
    return out


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        exe = shutil.which(name)
        if exe:
            return exe
    return None


def report_pdf(page: str, path: Path, *, figures=()) -> Path:
    """The whole page as one PDF, every scene section opened: printed by headless Chromium.

    Without Chromium the PDF holds the report's figures, one per page, after a first page
    that says so (the tables are in ``index.html`` and ``summary.md``).
    """
    exe = _chromium()
    if exe is not None:
        with tempfile.TemporaryDirectory() as tmp:
            opened = Path(tmp) / "page.html"
            opened.write_text(page.replace('<details class="scene-details">', '<details class="scene-details" open>'),
                              encoding="utf-8")
            out = Path(tmp) / "report.pdf"
            try:
                subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                                f"--user-data-dir={Path(tmp) / 'profile'}", "--no-pdf-header-footer",
                                f"--print-to-pdf={out}", opened.as_uri()], capture_output=True, timeout=300)
            except (OSError, subprocess.TimeoutExpired):
                pass
            if out.exists() and out.read_bytes().startswith(b"%PDF"):
                return atomic_write(path, out.read_bytes())
    from matplotlib.backends.backend_pdf import PdfPages  # deferred: matplotlib only when plotting (0.5-1.5 s)
    from matplotlib.figure import Figure  # deferred: matplotlib only when plotting (0.5-1.5 s)

    def write(tmp):
        with PdfPages(tmp) as pdf:
            note = Figure(figsize=(8.27, 2.0))
            note.text(0.05, 0.5, "The report's figures (Chromium was not found to print the whole page:\n"
                                 "the tables are in index.html and summary.md).", fontsize=11, va="center")
            pdf.savefig(note)
            for fig in figures:
                pdf.savefig(fig)

    return atomic_write(path, write)


def write_report(store, *, out=None, formats=("html",), metric: str = DEFAULT_METRIC) -> dict:
    """Write the report of a results store in the given formats.

    Parameters
    ----------
    store : str or Path
        The results store folder (see :func:`reports.store.load_store`).
    out : str or Path, optional
        Folder to write into (created if needed); default: the store folder.
    formats : sequence of {'html', 'svg', 'pdf', 'csv'}, keyword-only
        ``html``: ``index.html`` (self-contained) and ``summary.md``; ``svg``, ``pdf``: every
        plot as a vector file in ``plots/``, named ``<scene>_<W>x<H>_<metric>`` (the
        error-vs-time plot ``..._time-<metric>``); ``csv``: ``curves.csv`` and
        ``summary.csv`` (:mod:`reports.tidy`).
    metric : {'rmse', 'relmse', 'ssim', 'flip'}, keyword-only
        The error behind slopes, efficiency and time to target in tables and the time plot.

    Returns
    -------
    dict
        What was written: ``{"report": index.html, "summary": summary.md, "svg": plots/,
        "pdf": plots/, "curves.csv": ..., "summary.csv": ...}`` (the keys of the formats asked).

    Raises
    ------
    ValueError
        If ``store`` is not a results store, ``out`` exists and is not a folder, a format is
        unknown, or ``metric`` is unknown (or FLIP without its package).
    """
    formats = tuple(dict.fromkeys(formats))
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise ValueError(f"unknown report format(s) {bad or '(none)'}; choose from {', '.join(FORMATS)}")
    require_metric(metric)
    st = load_store(store)
    dest = Path(out).expanduser() if out is not None else st.path
    if dest.exists() and not dest.is_dir():
        raise ValueError(f"report output {str(dest)!r} exists and is not a folder")
    plots_folder = dest / "plots"
    if {"svg", "pdf"} & set(formats) and (plots_folder.is_symlink() or (plots_folder.exists()
                                                                        and not plots_folder.is_dir())):
        # A store received from elsewhere may hold a link here: writing through it would leave the output folder.
        raise ValueError(f"report output {str(plots_folder)!r} is a symbolic link or not a folder: remove it, or "
                         "give another output folder with --out")
    sections, cmp, seed_fig, problems = _collect(st, metric)
    dest.mkdir(parents=True, exist_ok=True)
    written = {}
    page = None
    if "html" in formats or "pdf" in formats:
        seed_png = plots.png_bytes(seed_fig) if seed_fig is not None else None
        page = page_html(st, sections, cmp, seed_png, problems, metric=metric)
    if "html" in formats:
        atomic_write(dest / "index.html", page)
        atomic_write(dest / "summary.md", _markdown(st, sections, cmp, problems, metric))
        written.update(report=dest / "index.html", summary=dest / "summary.md")
    for fmt_ in ("svg", "pdf"):
        if fmt_ in formats:
            _vector_files(dest, sections, seed_fig, fmt_)
            written[fmt_] = dest / "plots"
    if "pdf" in formats:
        written["report.pdf"] = report_pdf(page, dest / "report.pdf", figures=[
            fig for sec in sections for fig in sec.figures.values()] + ([seed_fig] if seed_fig is not None else []))
    if "csv" in formats:
        atomic_write(dest / "curves.csv", curves_csv(st))
        atomic_write(dest / "summary.csv", summary_csv(st))
        atomic_write(dest / "headline.csv", headline_csv(st))
        written.update({"curves.csv": dest / "curves.csv", "summary.csv": dest / "summary.csv",
                        "headline.csv": dest / "headline.csv"})
    return written


def build_report(store, *, out=None, formats=("html",), metric: str = DEFAULT_METRIC) -> Path:
    """Write the report (:func:`write_report`) and return its ``index.html``.

    Parameters
    ----------
    store, out, formats, metric
        As for :func:`write_report` (and raising as it does); ``html`` is always written.

    Returns
    -------
    Path
        The written ``index.html``.

    Examples
    --------
    >>> from reports import build_report
    >>> build_report("reports/out/quick")  # doctest: +SKIP
    PosixPath('reports/out/quick/index.html')
    """
    formats = ("html",) + tuple(f for f in formats if f != "html")
    return write_report(store, out=out, formats=formats, metric=metric)["report"]


def summary_table(store, *, metric: str = DEFAULT_METRIC) -> str:
    """A one-screen plain-text summary of a store: per scene and strategy, the key figures under ``metric``.

    Parameters
    ----------
    store : str, Path or Store
    metric : {'rmse', 'relmse', 'ssim', 'flip'}, keyword-only

    Returns
    -------
    str
    """
    st = store if isinstance(store, Store) else load_store(store)
    header = ["scene", "size", "strategy", f"{SPECS[metric].label} slope", "bias test", "bias", "eff/Mitsuba",
              "t->target s", "samples/s", "/Mitsuba"]
    rows = []
    for scene, w, h in st.sections():
        for r in (view(x, metric) for x in st.section_rows(scene, w, h)):
            rows.append([scene, f"{w}x{h}" if w and h else "?", curve_label(r["renderer"], r["strategy"]),
                         fmt(r.get("slope"), 3), verdict_cell(r), percent_text(r.get("relative_bias")),
                         r["cost_status"] or fmt(r.get("efficiency_vs_mitsuba"), 3),
                         r["cost_status"] or fmt(r.get("time_to_target"), 3),
                         fmt(r.get("samples_per_second"), 3), fmt(r.get("samples_per_second_vs_mitsuba"), 3)])
    text = f"metric: {SPECS[metric].label}\n" + (text_table(header, rows) if rows else "(summary.json holds no rows)")
    cmp = seed_comparison(st.records)
    if cmp is not None and math.isfinite(cmp["light_spp"]):
        text += (f"\nseed comparison ({SEED_SCENE} {SEED_SIZE}x{SEED_SIZE}): uniform at {SEED_SPP} spp has {cmp['label']} "
                 f"{fmt(cmp['target_rmse'], 3)}; light reaches it at ~{fmt(cmp['light_spp'], 3)} spp "
                 f"({cmp['method']})")
    return text
