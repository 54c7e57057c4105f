"""Assemble the report: ``index.html`` (self-contained) and ``summary.md`` from a results store."""
from __future__ import annotations

import base64
import datetime as _dt
import html
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import plots
from .assets import CSS, JS
from .curves import SEED_SCENE, SEED_SIZE, SEED_SPP, curve_label, curves, loglog_slope, seed_comparison
from .images import ERROR_CMAP, REL_EPS, display_png, error_map, error_png, error_range, pick_spps, \
    reference_exposure
from .store import Store, curve_order, load_store, num, read_image
from .tables import COLUMNS, FORMULAS, facts_table, fmt, markdown_table, stats_table, text_table

__all__ = ["build_report", "summary_table", "PLOT_KINDS"]

#: plot kinds of a section, in page order: (kind, record metric, caption).
PLOT_KINDS = ("rmse", "relmse", "ssim", "time")


def _e(s) -> str:
    return html.escape(str(s), quote=True)


def _data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _slug(*parts) -> str:
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
    equal_time: tuple = (math.nan, {})
    table: list = field(default_factory=list)
    rows: list = field(default_factory=list)
    target: float = math.nan
    image_rows: list = field(default_factory=list)  # [(spp, [Cell])]
    columns: list = field(default_factory=list)     # column labels of the image rows
    colourbar: bytes | None = None
    error_range: tuple | None = None
    exposure: float | None = None
    exposure_from: str = ""
    notes: list = field(default_factory=list)

    @property
    def title(self) -> str:
        size = f" ({self.width}×{self.height})" if self.width and self.height else ""
        return f"{self.scene}{size}"


# ----------------------------------------------------------------------------------------- sections

def _section(store: Store, scene: str, width, height, *, problems: list) -> Section:
    sec = Section(scene, width, height, id=_slug("scene", scene, width, height))
    recs = store.section_records(scene, width, height)
    sec.rows = store.section_rows(scene, width, height)
    sec.table = stats_table(sec.rows)
    targets = store.meta.get("target_rmse") if isinstance(store.meta.get("target_rmse"), dict) else {}
    sec.target = num(targets.get(scene))
    if not math.isfinite(sec.target):
        ts = [num(r.get("target_rmse")) for r in sec.rows if math.isfinite(num(r.get("target_rmse")))]
        sec.target = ts[0] if ts else math.nan
    if not recs:
        sec.notes.append("No job records for this scene and size: plots and images are unavailable.")
        return sec
    _section_plots(sec, recs)
    _section_images(store, sec, recs, problems=problems)
    return sec


def _section_plots(sec: Section, recs: list[dict]) -> None:
    title = sec.title
    rmse = curves(recs, "rmse")
    summary_slopes = {(r["renderer"], r["strategy"]): (num(r.get("slope")), "")
                      for r in sec.rows if math.isfinite(num(r.get("slope")))}
    slopes = {c.key: summary_slopes.get(c.key, (loglog_slope(c.spp, c.median), "fit here")) for c in rmse}
    if rmse:
        sec.plots["rmse"] = (plots.convergence_plot(rmse, title=f"{title}: RMSE vs spp", ylabel="RMSE",
                                                    slopes=slopes, guide_slope=-0.5, target=sec.target),
                             "RMSE against the reference vs samples per pixel (log-log). Lines: median over "
                             "seeds; bands: min to max; dashed: slope -1/2 (unbiased Monte Carlo). Legend "
                             "slopes are the harness's fits (summary.json) unless marked 'fit here'.")
    rel = curves(recs, "relmse")
    if rel:
        rslopes = {c.key: (loglog_slope(c.spp, c.median), "") for c in rel}
        sec.plots["relmse"] = (plots.convergence_plot(rel, title=f"{title}: relMSE vs spp", ylabel="relMSE",
                                                      slopes=rslopes, guide_slope=-1.0),
                               f"Relative MSE (eps = {REL_EPS:g}) vs spp. relMSE is a squared error, so its "
                               "unbiased slope is -1 (the dashed guide); legend slopes fitted here on the medians.")
    ss = curves(recs, "ssim")
    if ss:
        sec.plots["ssim"] = (plots.ssim_plot(ss, title=f"{title}: SSIM vs spp"),
                             "SSIM of the display image against the reference's (higher is better).")
    timed = [c for c in rmse if np.isfinite(c.seconds).any()]
    if timed:
        png, budget, at = plots.time_plot(timed, title=f"{title}: RMSE vs render time", target=sec.target)
        sec.equal_time = (budget, at)
        sec.plots["time"] = (png, "Speed against error: median RMSE vs median render seconds, one point per spp. "
                                  "Stars: each curve's RMSE at the equal-time budget (dotted), log-log "
                                  "interpolated.")
    missing = [k for k in PLOT_KINDS if k not in sec.plots]
    if missing:
        sec.notes.append(f"No data for plot(s): {', '.join(missing)}.")


def _reference(store: Store, sec: Section, *, problems: list):
    refs = store.meta.get("references") if isinstance(store.meta.get("references"), dict) else {}
    info = refs.get(sec.scene) if isinstance(refs.get(sec.scene), dict) else None
    if not info or not info.get("path"):
        sec.notes.append("meta.json names no reference image for this scene: no error maps.")
        return None
    path = store.resolve(info["path"])
    if not path.exists():
        problems.append(f"{sec.scene}: reference image {info['path']} is missing")
        sec.notes.append("The reference image is missing from the store: no error maps.")
        return None
    try:
        ref = read_image(path)
    except Exception as exc:  # noqa: BLE001 - a corrupt file is reported, not fatal
        problems.append(f"{sec.scene}: reference image {info['path']} could not be read ({exc})")
        return None
    if sec.width and sec.height and ref.shape[:2] != (sec.height, sec.width):
        sec.notes.append(f"The reference is {ref.shape[1]}×{ref.shape[0]}, not {sec.width}×{sec.height}: "
                         "no error maps at this size.")
        return None
    return ref


def _section_images(store: Store, sec: Section, recs: list[dict], *, problems: list) -> None:
    with_img = [r for r in recs if r.get("image")]
    if not with_img:
        sec.notes.append("No stored images for this scene and size.")
        return
    # per (curve, spp): the record with the lowest seed that has an image
    best: dict[tuple, dict] = {}
    for r in sorted(with_img, key=lambda r: (num(r.get("seed")) if math.isfinite(num(r.get("seed"))) else 1e18)):
        best.setdefault((r["renderer"], r["strategy"], float(r["spp"])), r)
    keys = sorted({(k[0], k[1]) for k in best}, key=curve_order)
    preferred = (4, 16, 64)
    spps = pick_spps({k[2] for k in best}, preferred=preferred)
    if sec.scene == SEED_SCENE and sec.width == SEED_SIZE and sec.height == SEED_SIZE \
            and float(SEED_SPP) in {k[2] for k in best} and float(SEED_SPP) not in spps:
        spps = sorted(spps[-2:] + [float(SEED_SPP)])
    ref = _reference(store, sec, problems=problems)

    cache: dict[str, np.ndarray | None] = {}

    def load(rec):
        rel = rec["image"]
        if rel not in cache:
            p = store.resolve(rel)
            try:
                cache[rel] = read_image(p) if p.exists() else None
            except Exception as exc:  # noqa: BLE001
                problems.append(f"{sec.scene}: image {rel} could not be read ({exc})")
                cache[rel] = None
            if cache[rel] is None and p is not None and not p.exists():
                problems.append(f"{sec.scene}: image {rel} is missing")
        return cache[rel]

    if ref is not None:
        sec.exposure, sec.exposure_from = reference_exposure(ref), "the reference"
    else:  # fall back to the most converged image: Mitsuba's if there is one, at its highest spp
        cands = sorted(best.items(), key=lambda kv: (kv[0][0] == "ours", -kv[0][2]))
        for (_, strat, spp), rec in cands:
            img = load(rec)
            if img is not None:
                sec.exposure = reference_exposure(img)
                sec.exposure_from = f"{curve_label(rec['renderer'], strat)} at {spp:g} spp (no reference)"
                break
    if sec.exposure is None:
        sec.notes.append("None of the stored images could be read.")
        return

    grid = []
    maps = {}
    for spp in spps:
        row = []
        for key in keys:
            cell = Cell(key=key, label=curve_label(*key), id=_slug("img", sec.id, key[0], key[1], f"{spp:g}"))
            rec = best.get((key[0], key[1], spp))
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
                seed = rec.get("seed")
                cell.caption = (f"RMSE {fmt(rec.get('rmse'), 3)} · relMSE {fmt(rec.get('relmse'), 3)} · "
                                f"SSIM {fmt(rec.get('ssim'), 3)} (seed {seed})")
            row.append(cell)
        if ref is not None:
            rc = Cell(key=("reference", ""), label="reference", id=_slug("ref", sec.id, f"{spp:g}"),
                      png=display_png(ref, sec.exposure))
            info = store.meta["references"][sec.scene]
            rc.caption = f"Mitsuba, {info.get('spp', '?')} spp, seed {info.get('seed', '?')}"
            row.append(rc)
        grid.append((spp, row))
    if maps:
        lo, hi = error_range(list(maps.values()))
        sec.error_range = (lo, hi)
        for _, row in grid:
            for cell in row:
                if cell.id in maps:
                    cell.err_png = error_png(maps[cell.id], lo, hi)
        sec.colourbar = plots.colourbar_png(lo, hi, cmap=ERROR_CMAP,
                                            label=f"per-pixel relative squared error (x−ref)²/(ref²+{REL_EPS:g})")
    sec.image_rows = grid
    sec.columns = [c.label for c in grid[0][1]] if grid else []


# ----------------------------------------------------------------------------------------- HTML

def _img(png: bytes, *, alt: str, cls: str = "", id_: str = "", extra: str = "") -> str:
    return (f'<img src="{_data_uri(png)}" alt="{_e(alt)}"' + (f' class="{cls}"' if cls else "")
            + (f' id="{_e(id_)}"' if id_ else "") + (f" {extra}" if extra else "") + ">")


def _stats_html(sec: Section) -> str:
    if not sec.table:
        return '<p class="note">summary.json holds no rows for this scene and size.</p>'
    head = "".join(f'<th title="{_e(tip)}">{_e(h)}</th>' for h, tip in COLUMNS)
    body = []
    for row, cells in zip(sec.rows, sec.table):
        tds = []
        for i, c in enumerate(cells):
            cls = ""
            if i == 0:
                c_html = f'<span class="swatch" style="background:{plots.colour((row["renderer"], row["strategy"]))}">' \
                         f'</span>{_e(c)}'
            else:
                c_html = _e(c)
            if COLUMNS[i][0] == "bias verdict":
                cls = {"biased": "biased", "no bias detected": "unbiased"}.get(c, "")
            tds.append(f'<td class="{cls}">{c_html}</td>' if cls else f"<td>{c_html}</td>")
        trc = ' class="mitsuba"' if row["renderer"] != "ours" else ""
        body.append(f"<tr{trc}>{''.join(tds)}</tr>")
    return (f'<div class="tablewrap"><table class="data" id="{sec.id}-table"><thead><tr>{head}</tr></thead>'
            f'<tbody>{"".join(body)}</tbody></table></div>'
            '<p class="note">Definitions and epsilons: <a href="#formulas">metric definitions</a>. '
            "Numbers are the harness's (summary.json), 4 significant digits.</p>")


def _equal_time_text(sec: Section) -> str:
    budget, at = sec.equal_time
    if not at:
        return ""
    parts = sorted(at.items(), key=lambda kv: curve_order(kv[0]))
    return (f"At equal time ({fmt(budget, 3)} s): " +
            ", ".join(f"{curve_label(*k)} RMSE {fmt(v, 3)}" for k, v in parts) + ".")


def _images_html(sec: Section) -> str:
    if not sec.image_rows:
        return ""
    n = len(sec.columns)
    out = [f'<div class="help">Images tone-mapped identically (exposure {fmt(sec.exposure, 3)} stops, from '
           f'{_e(sec.exposure_from)}: its median luminance to 18% grey, or its 99th percentile to white if brighter; '
           'sRGB). <b>Click</b> an image (or hover it and press <kbd>r</kbd>) to flip it '
           'with the reference; <kbd>R</kbd> flips the whole row, <kbd>Esc</kbd> restores all. Move the mouse over '
           'an image to zoom every column of its row into the same crop; <kbd>+</kbd>/<kbd>−</kbd> change the '
           'zoom. Under each image: left, the zoomed crop; right, the false-colour error map against the '
           'reference (colour bar below the rows).</div>']
    aspect = (sec.height / sec.width) if sec.width and sec.height else 1.0
    for spp, row in sec.image_rows:
        ref_id = next((c.id for c in row if c.key[0] == "reference"), "")
        lines = {"lbl": [], "shot": [], "sub": [], "cap": []}
        for c in row:
            lines["lbl"].append(f'<div class="cell lbl">{_e(c.label)}</div>')
            if c.png is None:
                lines["shot"].append(f'<div class="cell"><div class="empty">{_e(c.missing)}</div></div>')
                lines["sub"].append('<div class="cell"></div>')
                lines["cap"].append('<div class="cell"></div>')
                continue
            is_ref = c.key[0] == "reference"
            zid = c.id + "-zoom"
            attrs = f'data-zoom="{zid}"' + (f' data-ref="{ref_id}"' if ref_id and not is_ref else "")
            lines["shot"].append(
                f'<div class="cell"><div class="shotwrap{" is-ref" if is_ref else ""}" tabindex="0" {attrs}>'
                + _img(c.png, alt=f"{c.label} at {spp:g} spp", cls="shot", id_=c.id,
                       extra=f'data-kind="image" data-column="{_e(c.label)}" data-spp="{spp:g}"')
                + '<span class="badge">reference</span><span class="cropbox"></span></div></div>')
            sub = (f'<canvas class="zoom" id="{zid}" data-aspect="{aspect:.6g}" '
                   f'title="zoomed crop of {_e(c.label)}"></canvas>')
            if c.err_png is not None:
                sub += _img(c.err_png, alt=f"error map of {c.label} at {spp:g} spp", cls="err",
                            extra=f'title="error map of {_e(c.label)}" data-kind="error" '
                                  f'data-column="{_e(c.label)}" data-spp="{spp:g}"')
            lines["sub"].append(f'<div class="cell sub">{sub}</div>')
            lines["cap"].append(f'<div class="cell cap">{_e(c.caption)}</div>')
        grid = "".join("".join(v) for v in lines.values())
        out.append(f'<div class="cmp-row" data-spp="{spp:g}"><h4>{spp:g} spp '
                   f'<span class="note">(zoom <span class="zoomlevel">×4</span>)</span></h4>'
                   f'<div class="cmp-grid" style="grid-template-columns:repeat({n}, minmax(0, 1fr))">{grid}</div>'
                   "</div>")
    if sec.colourbar is not None:
        lo, hi = sec.error_range
        out.append('<div class="cbar">' + _img(sec.colourbar, alt="error map colour bar", extra='data-kind="colourbar"')
                   + f'<div class="note">Error maps: log scale from {fmt(lo, 3)} to {fmt(hi, 3)}, shared by every '
                   f"map of this scene (mean of a map = that image's relMSE).</div></div>")
    return "".join(out)


def _section_html(sec: Section) -> str:
    out = [f'<section class="card scene" id="{sec.id}" data-scene="{_e(sec.scene)}" '
           f'data-plots="{" ".join(k for k in PLOT_KINDS if k in sec.plots)}" '
           f'data-columns="{_e("|".join(sec.columns))}" '
           f'data-spps="{" ".join(f"{s:g}" for s, _ in sec.image_rows)}">',
           f"<h2>{_e(sec.title)}</h2>"]
    for note in sec.notes:
        out.append(f'<p class="note">{_e(note)}</p>')
    if sec.plots:
        out.append('<div class="plots">')
        for kind in PLOT_KINDS:
            if kind in sec.plots:
                png, cap = sec.plots[kind]
                out.append(f'<figure class="plot" id="{sec.id}-{kind}">'
                           + _img(png, alt=f"{sec.title} {kind} plot", extra=f'data-kind="plot" data-plot="{kind}"')
                           + f"<figcaption>{_e(cap)}</figcaption></figure>")
        out.append("</div>")
        et = _equal_time_text(sec)
        if et:
            out.append(f'<p class="note">{_e(et)}</p>')
    out.append("<h3>Per-strategy statistics</h3>" + _stats_html(sec))
    if sec.image_rows:
        out.append("<h3>Images at equal spp</h3>" + _images_html(sec))
    out.append("</section>")
    return "".join(out)


def _seed_lines(cmp: dict | None) -> tuple[list[str], list[list[str]]]:
    """Sentences and table rows of the seed comparison (shared by HTML and Markdown)."""
    if cmp is None:
        return ([f"This store holds no run of {SEED_SCENE} at {SEED_SIZE}×{SEED_SIZE} with both the uniform and "
                 "the light strategy, so the seed's comparison (uniform vs light sampling, and the spp at which "
                 f"light sampling reaches uniform's error at {SEED_SPP} spp) is not reproduced here."], [])
    uni, light = cmp["uniform"], cmp["light"]
    t = cmp["target_rmse"]
    lines = []
    if not math.isfinite(t):
        lines.append(f"Uniform sampling was not run at or around {SEED_SPP} spp (measured: "
                     f"{', '.join(f'{s:g}' for s in uni.spp)}), so there is no target error to match.")
    else:
        how = "median over seeds" if cmp["target_exact"] else "log-log interpolated between measured spp"
        lines.append(f"Uniform hemisphere sampling at {SEED_SPP} spp: RMSE {fmt(t)} ({how}).")
        ls = cmp["light_spp"]
        if cmp["method"] == "interpolated":
            lines.append(f"Light sampling reaches that RMSE at about {fmt(ls, 3)} spp (log-log interpolation of "
                         f"its median RMSE between measured spp): {fmt(cmp['saving'], 3)}× fewer samples.")
        elif cmp["method"] == "extrapolated":
            lines.append(f"Light sampling is already below that RMSE at its smallest measured spp "
                         f"({light.spp[0]:g}); extrapolating along its fitted slope ({fmt(cmp['light_slope'], 3)}) "
                         f"gives about {fmt(ls, 3)} spp: {fmt(cmp['saving'], 3)}× fewer samples.")
        elif cmp["method"] == "at most":
            lines.append(f"Light sampling is already below that RMSE at its smallest measured spp "
                         f"({light.spp[0]:g}).")
        else:
            lines.append(f"Light sampling does not reach that RMSE within its measured range (lowest median RMSE "
                         f"{fmt(float(np.min(light.median)))} at {light.spp[int(np.argmin(light.median))]:g} spp).")
        lines.append("Light sampling alone misses all indirect light: it is biased by design, so its curve "
                     "flattens at high spp (see its bias verdict in the table above).")
    spps = sorted(set(uni.spp.tolist()) | set(light.spp.tolist()))
    rows = []
    for s in spps:
        u = uni.median[uni.spp == s]
        li = light.median[light.spp == s]
        rows.append([f"{s:g}", fmt(u[0]) if u.size else "–", fmt(li[0]) if li.size else "–"])
    return lines, rows


def _seed_html(cmp: dict | None, png: bytes | None) -> str:
    lines, rows = _seed_lines(cmp)
    out = [f'<section class="card" id="seed" data-present="{"yes" if cmp else "no"}">'
           f"<h2>The seed's comparison: uniform vs light sampling on {SEED_SCENE}, "
           f"{SEED_SIZE}×{SEED_SIZE}</h2>"]
    if png is not None:
        out.append('<div class="plots"><figure class="plot" id="seed-plot">'
                   + _img(png, alt="seed comparison plot", extra='data-kind="plot" data-plot="seed"')
                   + "<figcaption>Median RMSE over seeds with min-max band; diamonds: uniform's error at "
                   f"{SEED_SPP} spp and where light sampling reaches it.</figcaption></figure><div>")
    out.append("".join(f'<p class="big">{_e(s)}</p>' for s in lines))
    if rows:
        out.append('<table class="data" style="width:auto"><thead><tr><th>spp</th><th>uniform RMSE</th>'
                   "<th>light RMSE</th></tr></thead><tbody>"
                   + "".join("<tr>" + "".join(f"<td>{_e(c)}</td>" for c in r) + "</tr>" for r in rows)
                   + '</tbody></table><p class="note">Median over seeds.</p>')
    if png is not None:
        out.append("</div></div>")
    out.append("</section>")
    return "".join(out)


def _page(store: Store, sections: list[Section], cmp, seed_png, problems: list) -> str:
    facts = facts_table(store.meta, n_records=len(store.records), n_raw=store.n_raw_records)
    title = f"rtbench report — {store.path.name}"
    toc = "".join(f'<a href="#{s.id}">{_e(s.title)}</a>' for s in sections)
    toc += '<a href="#seed">seed comparison</a><a href="#formulas">definitions</a>'
    if problems:
        toc += '<a href="#problems">problems</a>'
    preset = store.meta.get("preset") or "?"
    out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
           '<meta name="viewport" content="width=device-width, initial-scale=1">',
           f"<title>{_e(title)}</title><style>{CSS}</style></head><body>",
           f'<header class="top"><h1>{_e(title)}</h1><div class="sub">Our path tracer against Mitsuba 3 — '
           f"preset {_e(preset)}, {len(sections)} scene section(s), {len(store.records)} job records</div></header>",
           f'<nav class="toc">{toc}</nav><main>',
           '<section class="card" id="facts"><h2>Run facts</h2><table class="facts">'
           + "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in facts) + "</table></section>"]
    out += [_section_html(s) for s in sections]
    out.append(_seed_html(cmp, seed_png))
    out.append('<section class="card" id="formulas"><h2>Metric definitions</h2><dl class="formulas">'
               + "".join(f"<dt>{_e(k)}</dt><dd>{_e(v)}</dd>" for k, v in FORMULAS) + "</dl></section>")
    if problems:
        out.append('<section class="card" id="problems"><h2>Problems found in the store</h2><ul class="problems">'
                   + "".join(f"<li>{_e(p)}</li>" for p in problems) + "</ul></section>")
    out.append(f"</main><footer>Generated by rtbench reports on "
               f"{_e(_dt.datetime.now().isoformat(timespec='seconds'))} from {_e(store.path)}.</footer>"
               f"<script>{JS}</script></body></html>")
    return "\n".join(out)


# ----------------------------------------------------------------------------------------- Markdown

def _markdown(store: Store, sections: list[Section], cmp, problems: list) -> str:
    out = [f"# rtbench report — {store.path.name}", "", "## Run facts", "",
           markdown_table(["fact", "value"], facts_table(store.meta, n_records=len(store.records),
                                                         n_raw=store.n_raw_records)), ""]
    for sec in sections:
        out += [f"## {sec.title}", ""]
        if sec.table:
            out += [markdown_table([h for h, _ in COLUMNS], sec.table), ""]
        else:
            out += ["summary.json holds no rows for this scene and size.", ""]
        et = _equal_time_text(sec)
        if et:
            out += [et, ""]
        out += [f"- {n}" for n in sec.notes] + ([""] if sec.notes else [])
    lines, rows = _seed_lines(cmp)
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
    sections = [_section(store, *k, problems=problems) for k in store.sections()]
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
    tmp.write_text(_page(st, sections, cmp, seed_png, problems), encoding="utf-8")
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
                         fmt(r.get("slope"), 3), "BIASED" if sig is True else ("ok" if sig is False else "-"),
                         fmt(r.get("efficiency_vs_mitsuba"), 3), fmt(r.get("time_to_target"), 3),
                         fmt(r.get("samples_per_second"), 3), fmt(r.get("samples_per_second_vs_mitsuba"), 3)])
    text = text_table(header, rows) if rows else "(summary.json holds no rows)"
    cmp = seed_comparison(st.records)
    if cmp is not None and math.isfinite(cmp["light_spp"]):
        text += (f"\nseed comparison ({SEED_SCENE} {SEED_SIZE}x{SEED_SIZE}): uniform at {SEED_SPP} spp has RMSE "
                 f"{fmt(cmp['target_rmse'], 3)}; light reaches it at ~{fmt(cmp['light_spp'], 3)} spp "
                 f"({cmp['method']})")
    return text
