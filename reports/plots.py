"""Matplotlib (Agg) plots of a report section, each returned as a :class:`~matplotlib.figure.Figure`.

Figures are built with :class:`matplotlib.figure.Figure` and the Agg canvas directly, so no
pyplot state or display backend is involved; :func:`png_bytes` and :func:`figure_bytes`
render one as PNG (the page) or as SVG / PDF (vector files for a paper).
"""
from __future__ import annotations

import functools
import io
import math
import textwrap

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter, NullLocator

from benchmarks.constants import MITSUBA_DIRECT

from .curves import SEED_SPP, Curve, equal_time, loglog_slope
from .tables import fmt

__all__ = ["COLOURS", "colour", "convergence_plot", "ssim_plot", "time_plot", "seed_plot", "colourbar_png",
           "png_bytes", "figure_bytes"]

#: Okabe-Ito colours (colour-blind safe), fixed per strategy across every plot of the report.
COLOURS = {
    ("ours", "uniform"): "#E69F00",
    ("ours", "cosine"): "#56B4E9",
    ("ours", "light"): "#CC79A7",
    ("ours", "mixture"): "#009E73",
    ("ours", "mis"): "#0072B2",
}
_SPARE = ("#D55E00", "#F0E442", "#999999", "#8C564B")
DPI = 110


def colour(key: tuple[str, str]) -> str:
    """Plot colour of a (renderer, strategy) curve: Mitsuba black (under ``direct``, the colour of
    our strategy with the same sample counts), unknown strategies from a spare list."""
    if str(key[0]).startswith("ext-"):   # external renderers (benchmarks.external)
        return _SPARE[sum(map(ord, str(key[0]))) % len(_SPARE)]
    if key[0] == "mitsuba" and key[1] in MITSUBA_DIRECT:  # the colour of our strategy with its counts
        return COLOURS[("ours", MITSUBA_DIRECT[key[1]])]
    if key[0] != "ours":
        return "#000000"
    if key in COLOURS:
        return COLOURS[key]
    return _SPARE[sum(map(ord, str(key[1]))) % len(_SPARE)]


def _style(key) -> dict:
    mitsuba = key[0] != "ours"
    return {"color": colour(key), "marker": "s" if mitsuba else "o", "markersize": 4.5 if mitsuba else 4,
            "linewidth": 2.0 if mitsuba else 1.6, "linestyle": "-" if not mitsuba else (0, (5, 1.5)),
            "zorder": 4 if mitsuba else 3}


def png_bytes(fig: Figure) -> bytes:
    """Render a figure to PNG bytes."""
    return figure_bytes(fig, "png")


def figure_bytes(fig: Figure, fmt: str) -> bytes:
    """Render a figure as ``png``, ``svg`` or ``pdf`` bytes (vector text and lines for the latter two).

    SVG and PDF carry no creation date, so the same figure gives the same bytes.
    """
    if fmt not in ("png", "svg", "pdf"):
        raise ValueError(f"figure_bytes: unknown format {fmt!r}")
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    meta = {"png": None, "svg": {"Date": None}, "pdf": {"CreationDate": None, "ModDate": None}}[fmt]
    fig.savefig(buf, format=fmt, dpi=DPI, metadata=meta)
    return buf.getvalue()


def plain_text(plot):
    """Run a plotting function with mathtext off: titles and labels hold store fields
    (scene names), and a ``$`` in them must print as a ``$``, not start a formula that
    matplotlib parses (or fails to parse)."""
    @functools.wraps(plot)
    def wrapped(*args, **kwargs):
        with matplotlib.rc_context({"text.parse_math": False}):
            return plot(*args, **kwargs)

    return wrapped


def _new(title: str, *, size=(5.2, 4.5)):
    # Fixed margins, not a layout engine: constrained layout measured every tick label on each
    # save and took most of the report's time; the legend sits in the bottom band (_legend_below).
    fig = Figure(figsize=size, dpi=DPI)
    fig.subplots_adjust(left=0.14, right=0.97, top=0.93, bottom=0.43)
    ax = fig.add_subplot()
    ax.set_title(title, fontsize=10.5)
    ax.grid(True, which="major", alpha=0.35, linewidth=0.6)
    ax.grid(True, which="minor", alpha=0.12, linewidth=0.5)
    ax.tick_params(labelsize=8.5)
    return fig, ax


def _spp_ticks(ax, spps) -> None:
    u = np.unique(np.asarray(spps, dtype=float))
    u = u[u > 0]
    if 1 <= u.size <= 12:
        ax.xaxis.set_major_locator(FixedLocator(u))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda x, pos: f"{x:g}"))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.xaxis.set_minor_formatter(NullFormatter())


def _guide(ax, curves: list[Curve], slope: float, label: str) -> None:
    """Dashed reference line of a given log-log slope through the curves' geometric mean at their first spp."""
    starts = [(c.spp[0], c.median[0]) for c in curves if c.median[0] > 0]
    if not starts:
        return
    lo = min(s for s, _ in starts)
    hi = max(float(c.spp[-1]) for c in curves)
    if hi <= lo:
        return
    y0 = math.exp(np.mean([math.log(v) + slope * (math.log(lo) - math.log(s)) for s, v in starts]))
    xs = np.array([lo, hi])
    ax.plot(xs, y0 * (xs / lo) ** slope, color="#666666", linestyle=(0, (4, 3)), linewidth=1.1, label=label,
            zorder=2)


@plain_text
def convergence_plot(curves: list[Curve], *, title: str, ylabel: str, slopes: dict, guide_slope: float | None,
                     target: float | None = None) -> Figure:
    """Log-log metric vs spp: median over seeds with a min-max band, a dashed guide, slopes in the legend.

    Parameters
    ----------
    curves : list of Curve
    title, ylabel : str
    slopes : dict
        (renderer, strategy) -> (slope or None, note); ``note`` is appended to the legend
        entry (the budgets fitted, or why there is no slope).
    guide_slope : float or None
        Slope of the dashed guide (-0.5 for RMSE, -1 for relMSE); None: no guide.
    target : float, optional
        A horizontal dotted line (the target error).
    """
    if not curves:
        raise ValueError("convergence_plot: no curves to plot")
    fig, ax = _new(title)
    ax.set_xscale("log")
    ax.set_yscale("log")
    for c in curves:
        slope, note = slopes.get(c.key, (None, ""))
        lab = (f"{c.label}: slope {fmt(slope, 3)}" + (f" ({note})" if note else "") if slope is not None
               else f"{c.label}" + (f" ({note})" if note else ""))
        st = _style(c.key)
        if np.any(c.hi > c.lo):
            ax.fill_between(c.spp, np.maximum(c.lo, 1e-300), c.hi, color=st["color"], alpha=0.16, linewidth=0,
                            zorder=1)
        ax.plot(c.spp, c.median, label=lab, **st)
    if guide_slope is not None:
        _guide(ax, curves, guide_slope, f"slope {guide_slope:g} guide")
    if target is not None and math.isfinite(target) and target > 0:
        ax.axhline(target, color="#B22222", linestyle=":", linewidth=1.0, label=f"target {fmt(target, 3)}")
    _spp_ticks(ax, np.concatenate([c.spp for c in curves]))
    ax.set_xlabel("samples per pixel", fontsize=9)
    ax.set_ylabel(ylabel, fontsize=9)
    _legend_below(fig, ax)
    return fig


def _legend_below(fig, ax) -> None:
    """The legend under the axes, outside the data (long entries: slopes and their ranges)."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        # Long entries (a slope's range and why it has none) wrap within the figure's width;
        # many lines take a smaller font to stay inside the bottom band.
        labels = [textwrap.fill(lab, 84, subsequent_indent="    ") for lab in labels]
        lines = sum(lab.count("\n") + 1 for lab in labels)
        fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.55, 0.325), ncols=1,
                   fontsize=7.2 if lines <= 13 else 6.0, frameon=False)


@plain_text
def ssim_plot(curves: list[Curve], *, title: str) -> Figure:
    """SSIM vs spp (log x), median with min-max band."""
    if not curves:
        raise ValueError("ssim_plot: no curves to plot")
    fig, ax = _new(title)
    ax.set_xscale("log")
    lo = 1.0
    for c in curves:
        st = _style(c.key)
        if np.any(c.hi > c.lo):
            ax.fill_between(c.spp, c.lo, c.hi, color=st["color"], alpha=0.16, linewidth=0, zorder=1)
        ax.plot(c.spp, c.median, label=c.label, **st)
        lo = min(lo, float(np.nanmin(c.lo)))
    ax.set_ylim(max(-1.0, lo - 0.05 * (1.0 - lo) - 1e-3), 1.0 + 0.02 * (1.0 - lo) + 1e-3)
    ax.axhline(1.0, color="#666666", linewidth=0.8, linestyle=":")
    _spp_ticks(ax, np.concatenate([c.spp for c in curves]))
    ax.set_xlabel("samples per pixel", fontsize=9)
    ax.set_ylabel("SSIM (display sRGB; 1 = identical)", fontsize=9)
    _legend_below(fig, ax)
    return fig


@plain_text
def time_plot(curves: list[Curve], *, title: str, target: float | None = None,
              ylabel: str = "RMSE") -> tuple[Figure, float, dict]:
    """An error (``ylabel``: the metric) vs render seconds (log-log), one point per spp, with equal-time markers.

    Returns
    -------
    (figure, budget_seconds, {curve key: error at the budget})
    """
    timed = [c for c in curves if np.isfinite(c.seconds).any()]
    if not timed:
        raise ValueError("time_plot: no curve has render times")
    budget, at = equal_time(timed)
    fig, ax = _new(title)
    ax.set_xscale("log")
    ax.set_yscale("log")
    for c in timed:
        ok = np.isfinite(c.seconds) & (c.seconds > 0)
        order = np.argsort(c.seconds[ok])
        lab = c.label + (f"  ({fmt(at[c.key], 3)} at equal time)" if c.key in at else "")
        ax.plot(c.seconds[ok][order], c.median[ok][order], label=lab, **_style(c.key))
        if c.key in at:
            ax.plot([budget], [at[c.key]], marker="*", markersize=11, color=colour(c.key),
                    markeredgecolor="white", markeredgewidth=0.7, zorder=6, linestyle="none")
    if math.isfinite(budget):
        ax.axvline(budget, color="#444444", linestyle=":", linewidth=1.0, label=f"equal time {fmt(budget, 3)} s")
    if target is not None and math.isfinite(target) and target > 0:
        ax.axhline(target, color="#B22222", linestyle=":", linewidth=1.0, label=f"target {fmt(target, 3)}")
    ax.set_xlabel("render time (s)", fontsize=9)
    ax.set_ylabel(ylabel, fontsize=9)
    _legend_below(fig, ax)
    return fig, budget, at


@plain_text
def seed_plot(cmp: dict) -> Figure:
    """The seed's comparison: the error (``cmp["label"]``) vs spp of uniform and light at 400x400 with the matching point."""
    fig, ax = _new("cornell_box 400x400: uniform vs light sampling", size=(5.6, 4.5))
    ax.set_xscale("log")
    ax.set_yscale("log")
    for name in ("uniform", "light"):
        c = cmp[name]
        st = _style(c.key)
        if np.any(c.hi > c.lo):
            ax.fill_between(c.spp, c.lo, c.hi, color=st["color"], alpha=0.16, linewidth=0)
        ax.plot(c.spp, c.median, label=f"{name} (slope {fmt(loglog_slope(c.spp, c.median), 3)})", **st)
    t = cmp["target_rmse"]
    if math.isfinite(t):
        ax.axhline(t, color="#444444", linestyle=":", linewidth=1.0,
                   label=f"uniform at {SEED_SPP} spp: {cmp.get('label', 'RMSE')} {fmt(t, 3)}")
        ax.plot([SEED_SPP], [t], marker="D", color=colour(("ours", "uniform")), markersize=7, zorder=6,
                markeredgecolor="black", linestyle="none")
    if math.isfinite(cmp["light_spp"]):
        ax.axvline(cmp["light_spp"], color=colour(("ours", "light")), linestyle=":", linewidth=1.0,
                   label=f"light reaches it at {fmt(cmp['light_spp'], 3)} spp ({cmp['method']})")
        ax.plot([cmp["light_spp"]], [t], marker="D", color=colour(("ours", "light")), markersize=7, zorder=6,
                markeredgecolor="black", linestyle="none")
    spps = np.concatenate([cmp["uniform"].spp, cmp["light"].spp])
    _spp_ticks(ax, spps)
    ax.set_xlabel("samples per pixel", fontsize=9)
    ax.set_ylabel(f"{cmp.get('label', 'RMSE')} (median over seeds)", fontsize=9)
    _legend_below(fig, ax)
    return fig


def colourbar_png(vmin: float, vmax: float, *, cmap: str, label: str, log: bool = True) -> bytes:
    """A horizontal colour bar (PNG) for the false-colour error maps."""
    from matplotlib.colors import LogNorm, Normalize  # deferred: matplotlib only when plotting (0.5-1.5 s)
    from matplotlib.cm import ScalarMappable  # deferred: matplotlib only when plotting (0.5-1.5 s)

    fig = Figure(figsize=(6.0, 0.8), dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    norm = LogNorm(vmin, vmax) if log else Normalize(vmin, vmax)
    cb = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), cax=ax, orientation="horizontal")
    cb.set_label(label, fontsize=9)
    cb.ax.tick_params(labelsize=8.5)
    return png_bytes(fig)
