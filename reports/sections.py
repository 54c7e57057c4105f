"""What each part of the report shows, as data: a scene section's plots, table and image rows.

Shared by the HTML page (:mod:`reports.html`) and the Markdown summary
(:mod:`reports.build`); nothing here writes HTML.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from benchmarks.constants import MITSUBA_DIRECT, RELMSE_EPS, SEED_SCENE, SEED_SIZE, SEED_SPP
from benchmarks.display import reference_exposure
from benchmarks.metrics import DEFAULT_METRIC, SPECS, view

from . import plots
from .curves import curve_label, curves
from .images import (ERROR_CMAP, FLIP_CMAP, display_png, error_map, error_png, error_range, flip_map, flip_png,
                     pick_spps)
from .store import Store, curve_order, num
from .tables import fmt, reference_caption, stats_table

__all__ = ["PLOT_KINDS", "Cell", "Section", "build_section", "equal_time_text", "seed_lines", "slug",
           "metric_records"]

#: plot kinds of a section, in page order: the section's metric's convergence plot (one of the
#: first four) and "time", that metric's error vs render time.
PLOT_KINDS = ("rmse", "relmse", "ssim", "flip", "time")


def slug(*parts) -> str:
    s = "-".join(str(p) for p in parts if p is not None)
    return re.sub(r"[^a-z0-9]+", "-", s.lower()).strip("-") or "x"


@dataclass
class Cell:
    """One column of an equal-spp image row."""

    key: tuple          # (renderer, strategy) or ("reference", "")
    label: str
    id: str = ""
    png: bytes | None = None
    err_png: bytes | None = None
    flip_png: bytes | None = None
    caption: str = ""
    missing: str = ""


@dataclass
class Section:
    """Everything shown for one (scene, width, height)."""

    scene: str
    width: int | None
    height: int | None
    id: str
    plots: dict = field(default_factory=dict)       # kind -> (png, caption)
    figures: dict = field(default_factory=dict)     # kind -> matplotlib Figure (for SVG / PDF files)
    metric: str = DEFAULT_METRIC
    equal_time: tuple = (math.nan, {})
    table: list = field(default_factory=list)
    rows: list = field(default_factory=list)       # summary rows as seen under ``metric`` (views)
    raw_rows: list = field(default_factory=list)   # summary rows as stored
    target: float = math.nan
    image_rows: list = field(default_factory=list)  # [(spp, [Cell])]
    columns: list = field(default_factory=list)     # column labels of the image rows
    colourbar: bytes | None = None
    flip_colourbar: bytes | None = None
    error_range: tuple | None = None
    exposure: float | None = None
    exposure_from: str = ""
    notes: list = field(default_factory=list)

    @property
    def title(self) -> str:
        size = f" ({self.width}×{self.height})" if self.width and self.height else ""
        return f"{self.scene}{size}"


# ----------------------------------------------------------------------------------------- sections

def build_section(store: Store, scene: str, width, height, *, problems: list,
                  metric: str = DEFAULT_METRIC) -> Section:
    """Plots, statistics table and image rows of one (scene, width, height) under ``metric``; problems appended."""
    sec = Section(scene, width, height, id=slug("scene", scene, width, height), metric=metric)
    recs = store.section_records(scene, width, height)
    sec.raw_rows = store.section_rows(scene, width, height)
    sec.rows = [view(r, metric) for r in sec.raw_rows]
    sec.table = stats_table(sec.rows)
    if metric == "rmse":
        targets = store.meta.get("target_rmse") if isinstance(store.meta.get("target_rmse"), dict) else {}
        sec.target = num(targets.get(scene))
    else:
        sec.target = num(SPECS[metric].target)
    if not math.isfinite(sec.target):
        ts = [num(r.get("target")) for r in sec.rows if math.isfinite(num(r.get("target")))]
        sec.target = ts[0] if ts else math.nan
    if sec.rows and metric != "rmse" and all(not r.get("by_metric") for r in sec.rows):
        sec.notes.append(f"summary.json predates per-metric figures: no {SPECS[metric].label} slopes, efficiency "
                         "or time to target (rerun the sweep, which resumes, to add them; or use --metric rmse).")
    if not recs:
        sec.notes.append("No job records for this scene and size: plots and images are unavailable.")
        return sec
    _section_plots(sec, recs)
    _section_images(store, sec, recs, problems=problems)
    return sec


def metric_records(recs: list[dict], metric: str) -> list[dict]:
    """Records with ``_err``: the metric's error of each (RMSE, relMSE, 1 - SSIM or FLIP), as the summary uses it.

    >>> metric_records([{"ssim": 0.75}], "ssim")[0]["_err"]
    0.25
    """
    field = PLOT_FIELDS[metric]
    if not any(r.get(field) is not None for r in recs):
        field = {"relmse_corrected": "relmse"}.get(field, field)  # stores without the corrected figure
    out = []
    for r in recs:
        v = num(r.get(field))
        out.append(dict(r, _err=(1.0 - v) if metric == "ssim" else v))
    return out


def _slopes(sec: Section, cs, metric: str) -> dict:
    """Legend slopes: the summary's under ``metric`` (fitted to four or more budgets, with the
    range fitted, flagged when steeper than Monte Carlo allows); ``(None, why)`` where it has none."""
    out = {}
    for r in sec.raw_rows:
        v = view(r, metric)
        s, rng = num(v.get("slope")), v.get("slope_range")
        key = (r["renderer"], r["strategy"])
        if math.isfinite(s):
            note = f"{rng[0]:g}–{rng[1]:g} spp" if isinstance(rng, (list, tuple)) and len(rng) == 2 else ""
            if v.get("slope_steep"):
                note += ", steeper than Monte Carlo: low budgets read low"
            out[key] = (s, note)
        elif r.get("exact"):
            out[key] = (None, "exact: zero error, off the log axes")
        else:
            out[key] = (None, f"no slope: {r.get('slope_status') or 'fewer than four budgets'}")
    return {c.key: out.get(c.key, (None, "not in the summary")) for c in cs}


def _add_plot(sec: Section, kind: str, fig, caption: str) -> None:
    sec.figures[kind] = fig
    sec.plots[kind] = (plots.png_bytes(fig), caption)


#: the record field behind each metric's convergence plot (relMSE and MSE less the reference's noise).
PLOT_FIELDS = {"rmse": "rmse", "relmse": "relmse_corrected", "ssim": "ssim", "flip": "flip"}


def _section_plots(sec: Section, recs: list[dict]) -> None:
    """Two plots, both in the section's metric: its convergence with spp, and its error against time."""
    title, metric, spec = sec.title, sec.metric, SPECS[sec.metric]
    field = PLOT_FIELDS[metric]
    if field == "relmse_corrected" and not any(r.get(field) is not None for r in recs):
        field = "relmse"  # stores written before the corrected figure was recorded
    cs = curves(recs, field)
    exact = [r for r in sec.raw_rows if r.get("exact")]
    if cs and metric == "ssim":
        _add_plot(sec, metric, plots.ssim_plot(cs, title=f"{title}: SSIM vs spp"),
                  "SSIM of the display image against the reference's (higher is better).")
    elif cs:
        guide = spec.unbiased_slope
        _add_plot(sec, metric, plots.convergence_plot(
            cs, title=f"{title}: {spec.label} vs spp", ylabel=spec.label + (" (reference noise removed)"
                                                                          if field.endswith("_corrected") else ""),
            slopes=_slopes(sec, cs, metric), guide_slope=guide, target=sec.target),
            f"{spec.label} against the reference vs samples per pixel (log-log); lines: median over seeds, bands: min "
            "to max" + (f"; dashed: slope {guide:g} (unbiased Monte Carlo)" if guide is not None else "") +
            ". Legend slopes are the summary's, fitted to four or more rendered budgets (the range fitted is given)."
            + (f" Exact estimators ({', '.join(curve_label(r['renderer'], r['strategy']) for r in exact)}) have zero "
               "error and are off the log axes." if exact else ""))
    if cs and metric != "ssim":
        _direct_plot(sec, cs, field)
    spec = SPECS[sec.metric]
    timed, modelled = _timed_curves(sec, recs)
    if timed:
        fig, budget, at = plots.time_plot(timed, title=f"{title}: {spec.label} vs render time", target=sec.target,
                                          ylabel=spec.label)
        sec.equal_time = (budget, at)
        how = ("render time = spp × pixels × the estimator's seconds per sample, timed on its seconds-long "
               "high-budget render (our tail reference, Mitsuba's reference): the small renders of the sweep take "
               "milliseconds, mostly per-render overhead" if modelled else
               "median render seconds of the sweep's renders (no high-budget timing in the summary)")
        _add_plot(sec, "time", fig,
                  f"Speed against error ({spec.label}, the report's metric), one point per spp; {how}. Stars: each "
                  "curve's error at the equal-time budget (dotted), log-log interpolated.")
    missing = [k for k in PLOT_KINDS if k not in sec.plots]
    if missing:
        sec.notes.append(f"No data for plot(s): {', '.join(missing)}.")


#: Veach's comparison under Mitsuba's ``direct``: (technique, our curve, Mitsuba's curve).
DIRECT_TECHNIQUES = tuple((label, ("ours", MITSUBA_DIRECT[name]), ("mitsuba", name)) for label, name in
                          (("BSDF sampling", "direct_bsdf"), ("light sampling", "direct_light"), ("MIS", "direct_mis")))
#: The budget whose images Veach's comparison shows (the nearest rendered one): noisy enough
#: to tell the techniques apart at a glance.
DIRECT_SPP = 16


def _direct_plot(sec: Section, cs, field: str) -> None:
    """Veach's comparison, for a scene with Mitsuba's ``direct``: the error of BSDF sampling,
    light sampling and MIS against spp, ours and Mitsuba's with the same sample counts."""
    keys = [k for _, ours, mits in DIRECT_TECHNIQUES for k in (ours, mits)]
    chosen = sorted((c for c in cs if c.key in keys), key=lambda c: keys.index(c.key))
    if not any(c.key[0] == "mitsuba" for c in chosen):
        return
    spec = SPECS[sec.metric]
    _add_plot(sec, "direct", plots.convergence_plot(
        chosen, title=f"{sec.title}: BSDF vs light sampling vs MIS", ylabel=spec.label + (
            " (reference noise removed)" if field.endswith("_corrected") else ""),
        slopes=_slopes(sec, chosen, sec.metric), guide_slope=spec.unbiased_slope, target=None),
        f"{spec.label} vs samples per pixel of the three techniques of Mitsuba's direct integrator, ours "
        "(solid) beside Mitsuba's (dashed, same colour) with the same emitter and BSDF sample counts; lines: "
        "median over seeds, bands: min to max.")


def direct_images(sec: Section) -> tuple:
    """``(spp, [(technique, our Cell or None, Mitsuba's Cell or None)])`` of Veach's comparison
    at the rendered budget nearest :data:`DIRECT_SPP` where the images are; ``(None, [])``
    for a scene without Mitsuba's ``direct`` curves."""
    rows = [(spp, {c.key: c for c in cells if c.png is not None}) for spp, cells in sec.image_rows]
    keys = [k for _, ours, mits in DIRECT_TECHNIQUES for k in (ours, mits)]
    rows = [(spp, cells) for spp, cells in rows if any(k in cells for k in keys if k[0] == "mitsuba")]
    if not rows:
        return None, []
    spp, cells = min(rows, key=lambda r: (-sum(k in r[1] for k in keys), abs(math.log(r[0] / DIRECT_SPP))))
    return spp, [(label, cells.get(ours), cells.get(mits)) for label, ours, mits in DIRECT_TECHNIQUES]


def _timed_curves(sec: Section, recs: list[dict]) -> tuple:
    """``(curves, modelled)``: the section metric's curves with a time per spp. Where the summary
    gives a curve's seconds per sample (``seconds_per_sample``), its time at ``n`` spp is
    ``n`` x pixels x that (``modelled``); else its renders' median seconds."""
    sps = {(r["renderer"], r["strategy"]): num(r.get("seconds_per_sample")) for r in sec.raw_rows}
    pixels = (sec.width or 0) * (sec.height or 0)
    out, modelled = [], False
    for c in curves(metric_records(recs, sec.metric), "_err"):
        t = sps.get(c.key, math.nan)
        if math.isfinite(t) and t > 0 and pixels:
            c.seconds = c.spp * pixels * t
            modelled = True
        if np.isfinite(c.seconds).any():
            out.append(c)
    return out, modelled


def reference_info(store: Store, scene: str, width, height) -> dict | None:
    """``meta.json``'s entry of the reference of one section: the one rendered at its size
    (``references_by_size``), else the scene's main one (``references``; stores of older runs)."""
    by_size = store.meta.get("references_by_size") or {}
    info = by_size.get(f"{scene}@{width}x{height}")
    if info is None:
        info = (store.meta.get("references") or {}).get(scene)
    return info if isinstance(info, dict) else None


def _reference(store: Store, sec: Section, *, problems: list):
    info = reference_info(store, sec.scene, sec.width, sec.height)
    if not info or not info.get("path"):
        sec.notes.append("meta.json names no reference image for this scene: no error maps.")
        return None
    try:
        ref = store.read_image(info["path"], sha256=info.get("sha256"))
    except Exception as exc:  # noqa: BLE001 - a corrupt or misplaced file is reported, never used
        problems.append(f"{sec.scene}: reference image {info['path']!r:.200} could not be read ({exc})")
        sec.notes.append("The reference image is corrupt or not in the store: no error maps.")
        return None
    if ref is None:
        problems.append(f"{sec.scene}: reference image {info['path']!r:.200} is missing")
        sec.notes.append("The reference image is missing from the store: no error maps.")
        return None
    if sec.width and sec.height and ref.shape[:2] != (sec.height, sec.width):
        sec.notes.append(f"The reference is {ref.shape[1]}×{ref.shape[0]}, not {sec.width}×{sec.height}: "
                         "no error maps at this size.")
        return None
    return ref


def _section_images(store: Store, sec: Section, recs: list[dict], *, problems: list) -> None:
    """The equal-spp image rows: one column per curve plus the reference, error maps under each."""
    best = _best_images(recs)
    if not best:
        sec.notes.append("No stored images for this scene and size.")
        return
    keys = sorted({(k[0], k[1]) for k in best}, key=curve_order)
    spps = pick_spps({k[2] for k in best}, preferred=(4, 16, 64))
    if sec.scene == SEED_SCENE and sec.width == SEED_SIZE and sec.height == SEED_SIZE \
            and float(SEED_SPP) in {k[2] for k in best} and float(SEED_SPP) not in spps:
        spps = sorted(spps[-2:] + [float(SEED_SPP)])
    ref = _reference(store, sec, problems=problems)
    load = _image_loader(store, sec, problems)
    _choose_exposure(sec, ref, best, load)
    if sec.exposure is None:
        sec.notes.append("None of the stored images could be read.")
        return
    grid, maps = [], {}
    for spp in spps:
        row = [_image_cell(sec, key, spp, best.get((key[0], key[1], spp)), recs, load, ref, maps, problems)
               for key in keys]
        if ref is not None:
            rc = Cell(key=("reference", ""), label="reference", id=slug("ref", sec.id, f"{spp:g}"),
                      png=display_png(ref, sec.exposure))
            rc.caption = reference_caption(reference_info(store, sec.scene, sec.width, sec.height) or {})
            row.append(rc)
        grid.append((spp, row))
    if maps:
        _error_maps(sec, grid, maps)
    sec.image_rows = grid
    sec.columns = [c.label for c in grid[0][1]] if grid else []


def _best_images(recs: list[dict]) -> dict[tuple, dict]:
    """Per (renderer, strategy, spp): the record with the lowest seed that has an image."""
    with_img = [r for r in recs if r.get("image")]
    best: dict[tuple, dict] = {}
    for r in sorted(with_img, key=lambda r: (num(r.get("seed")) if math.isfinite(num(r.get("seed"))) else 1e18)):
        best.setdefault((r["renderer"], r["strategy"], float(r["spp"])), r)
    return best


def _image_loader(store: Store, sec: Section, problems: list):
    """A function record -> image (or None), reading each file once and noting missing or bad files."""
    cache: dict[str, np.ndarray | None] = {}

    def load(rec):
        rel = rec["image"]
        if not isinstance(rel, str):
            rel = repr(rel)
        if rel not in cache:
            try:
                cache[rel] = store.read_image(rel)
                if cache[rel] is None:
                    problems.append(f"{sec.scene}: image {rel!r:.200} is missing")
            except Exception as exc:  # noqa: BLE001 - a corrupt or misplaced file is reported, not fatal
                problems.append(f"{sec.scene}: image {rel!r:.200} could not be read ({exc})")
                cache[rel] = None
        return cache[rel]

    return load


def _choose_exposure(sec: Section, ref, best: dict, load) -> None:
    """One exposure for the section: the reference's, else the most converged image's."""
    if ref is not None:
        sec.exposure, sec.exposure_from = reference_exposure(ref), "the reference"
        return
    # no reference: Mitsuba's image if there is one, at its highest spp
    cands = sorted(best.items(), key=lambda kv: (kv[0][0] == "ours", -kv[0][2]))
    for (_, strat, spp), rec in cands:
        img = load(rec)
        if img is not None:
            sec.exposure = reference_exposure(img)
            sec.exposure_from = f"{curve_label(rec['renderer'], strat)} at {spp:g} spp (no reference)"
            return


def _image_cell(sec: Section, key: tuple, spp: float, rec, recs: list[dict], load, ref, maps: dict,
                problems: list) -> Cell:
    """One column of an image row; its error map (against ``ref``) goes into ``maps``."""
    cell = Cell(key=key, label=curve_label(*key), id=slug("img", sec.id, key[0], key[1], f"{spp:g}"))
    flips = maps.setdefault("_flip", {})
    img = load(rec) if rec else None
    if rec is None:
        cell.missing = "not rendered at this spp" if not any(
            r["renderer"] == key[0] and r["strategy"] == key[1] and float(r["spp"]) == spp for r in recs) \
            else "no stored image"
    elif img is None:
        cell.missing = "image missing"
    elif sec.height and img.shape[:2] != (sec.height, sec.width):
        cell.missing = f"image is {img.shape[1]}×{img.shape[0]}"
        problems.append(f"{sec.scene}: image {rec['image']} has size {img.shape[1]}x{img.shape[0]}, "
                        f"expected {sec.width}x{sec.height}")
    else:
        cell.png = display_png(img, sec.exposure)
        if ref is not None:
            maps[cell.id] = error_map(img, ref)
            fm = flip_map(img, ref)
            if fm is not None:
                flips[cell.id] = fm
        seed = rec.get("seed")
        field = {"rmse": "rmse", "relmse": "relmse", "ssim": "ssim", "flip": "flip"}[sec.metric]
        cell.caption = f"{SPECS[sec.metric].label if sec.metric != 'ssim' else 'SSIM'} " \
                       f"{fmt(rec.get(field), 3)} (seed {seed})"
    return cell


def _error_maps(sec: Section, grid: list, maps: dict) -> None:
    """False-colour PNGs of the error maps on one log scale per section, and its colour bar; FLIP maps on 0..1."""
    flips = maps.pop("_flip", {})
    for _, row in grid:
        for cell in row:
            if cell.id in flips:
                cell.flip_png = flip_png(flips[cell.id])
    if flips:
        sec.flip_colourbar = plots.colourbar_png(0.0, 1.0, cmap=FLIP_CMAP, log=False,
                                                 label="per-pixel FLIP (0 = no visible difference, 1 = largest)")
    if not maps:
        return
    lo, hi = error_range(list(maps.values()))
    sec.error_range = (lo, hi)
    for _, row in grid:
        for cell in row:
            if cell.id in maps:
                cell.err_png = error_png(maps[cell.id], lo, hi)
    sec.colourbar = plots.colourbar_png(lo, hi, cmap=ERROR_CMAP,
                                        label=f"per-pixel relative squared error (x−ref)²/(ref²+{RELMSE_EPS:g})")


def equal_time_text(sec: Section) -> str:
    """The sentence comparing the curves' error (the section's metric) at equal render time (empty when none)."""
    budget, at = sec.equal_time
    if not at:
        return ""
    label = SPECS[sec.metric].label
    parts = sorted(at.items(), key=lambda kv: curve_order(kv[0]))
    return (f"At equal time ({fmt(budget, 3)} s): " +
            ", ".join(f"{curve_label(*k)} {label} {fmt(v, 3)}" for k, v in parts) + ".")


def seed_lines(cmp: dict | None) -> tuple[list[str], list[list[str]]]:
    """Sentences and table rows of the seed comparison (shared by HTML and Markdown); none without it.

    A store without the seed's runs gets no seed section at all (a custom run is not
    missing anything).
    """
    if cmp is None:
        return [], []
    uni, light = cmp["uniform"], cmp["light"]
    t = cmp["target_rmse"]
    lines = []
    if not math.isfinite(t):
        lines.append(f"Uniform sampling was not run at or around {SEED_SPP} spp (measured: "
                     f"{', '.join(f'{s:g}' for s in uni.spp)}), so there is no target error to match.")
    else:
        how = "median over seeds" if cmp["target_exact"] else "log-log interpolated between measured spp"
        lines.append(f"Uniform hemisphere sampling at {SEED_SPP} spp: {cmp['label']} {fmt(t)} ({how}).")
        ls = cmp["light_spp"]
        if cmp["method"] == "interpolated":
            lines.append(f"Light sampling reaches that {cmp['label']} at about {fmt(ls, 3)} spp (log-log interpolation "
                         f"of its median {cmp['label']} between measured spp): {fmt(cmp['saving'], 3)}× fewer samples.")
        elif cmp["method"] == "at most":
            lines.append(f"Light sampling is already below that {cmp['label']} at its smallest measured spp "
                         f"({light.spp[0]:g}: {cmp['label']} {fmt(float(light.median[0]), 3)}), at least "
                         f"{fmt(cmp['saving'], 3)}× fewer samples.")
        else:
            lines.append(f"Light sampling does not reach that {cmp['label']} within its measured range (lowest median "
                         f"{cmp['label']} {fmt(float(np.min(light.median)))} at "
                         f"{light.spp[int(np.argmin(light.median))]:g} spp).")
        lines.append("Light sampling alone misses all indirect light: it is biased by design, so its curve "
                     "flattens at high spp (see its bias verdict in the table above).")
    spps = sorted(set(uni.spp.tolist()) | set(light.spp.tolist()))
    rows = []
    for s in spps:
        u = uni.median[uni.spp == s]
        li = light.median[light.spp == s]
        rows.append([f"{s:g}", fmt(u[0]) if u.size else "–", fmt(li[0]) if li.size else "–"])
    return lines, rows
