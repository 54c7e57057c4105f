"""The report's HTML: one self-contained page (images inline as data URIs, CSS and JS inline)."""
from __future__ import annotations

import base64
import html

from benchmarks.constants import SEED_LIGHT_SPP, SEED_SCENE, SEED_SIZE, SEED_SPP
from benchmarks.metrics import SPECS
from benchmarks.store import timestamp

from . import plots
from .assets import CSS, JS
from .headline import HEADLINE_NOTE, headline_cells, headline_entries, headline_header, verdict_text
from .sections import PLOT_KINDS, Section, direct_images, equal_time_text, seed_lines
from .store import Store
from .tables import FORMULAS, columns, facts_table, fmt

__all__ = ["page_html"]


def _e(s) -> str:
    return html.escape(str(s), quote=True)


def _data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")



def _img(png: bytes, *, alt: str, cls: str = "", id_: str = "", extra: str = "") -> str:
    return (f'<img src="{_data_uri(png)}" alt="{_e(alt)}"' + (f' class="{cls}"' if cls else "")
            + (f' id="{_e(id_)}"' if id_ else "") + (f" {extra}" if extra else "") + ">")


def _stats_html(sec: Section) -> str:
    if not sec.table:
        return '<p class="note">summary.json holds no rows for this scene and size.</p>'
    cols = columns(sec.metric)
    head = "".join(f'<th title="{_e(tip)}">{_e(h)}</th>' for h, tip in cols)
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
            if cols[i][0] == "bias test":
                cls = "biased" if c == "fail" else "unbiased" if c == "pass" else "nocost" if c != "–" else ""
            elif c in ("biased", "undetermined"):
                cls = "nocost"
            tds.append(f'<td class="{cls}">{c_html}</td>' if cls else f"<td>{c_html}</td>")
        trc = ' class="mitsuba"' if row["renderer"] != "ours" else ""
        body.append(f"<tr{trc}>{''.join(tds)}</tr>")
    return (f'<div class="tablewrap"><table class="data" id="{sec.id}-table"><thead><tr>{head}</tr></thead>'
            f'<tbody>{"".join(body)}</tbody></table></div>'
            f'<p class="note">Metric: <b>{_e(sec.rows[0]["metric_label"] if sec.rows else sec.metric)}</b> '
            f"(slopes, efficiency, time to target; --metric); target {_e(fmt(sec.target, 3))}. Efficiency and time to "
            "target are shown only where no bias was detected. Definitions and epsilons: <a href=\"#formulas\">"
            "metric definitions</a>. Numbers are the harness's (summary.json).</p>")




def _images_html(sec: Section) -> str:
    if not sec.image_rows:
        return ""
    n = len(sec.columns)
    out = [f'<div class="help">Images tone-mapped identically (exposure {fmt(sec.exposure, 3)} stops, from '
           f'{_e(sec.exposure_from)}: its median luminance to 18% grey, or its 99th percentile to white if brighter; '
           'sRGB). <b>Click</b> an image (or hover it and press <kbd>r</kbd>) to flip it '
           'with the reference; <kbd>R</kbd> flips the whole row, <kbd>Esc</kbd> restores all. Move the mouse over '
           'an image to zoom every column of its row into the same crop; <kbd>+</kbd>/<kbd>−</kbd> change the '
           'zoom. Under each image: the zoomed crop, the relative squared error map and the FLIP map against '
           'the reference (colour bars below the rows).</div>']
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
            if c.flip_png is not None:
                sub += _img(c.flip_png, alt=f"FLIP map of {c.label} at {spp:g} spp", cls="err flipmap",
                            extra=f'title="FLIP map of {_e(c.label)}" data-kind="flip" '
                                  f'data-column="{_e(c.label)}" data-spp="{spp:g}"')
            lines["sub"].append(f'<div class="cell sub{" three" if c.flip_png is not None else ""}">{sub}</div>')
            lines["cap"].append(f'<div class="cell cap">{_e(c.caption)}</div>')
        grid = "".join("".join(v) for v in lines.values())
        out.append(f'<div class="cmp-row" data-spp="{spp:g}"><h4>{spp:g} spp '
                   f'<span class="note">(zoom <span class="zoomlevel">×4</span>)</span></h4>'
                   f'<div class="cmp-scroll"><div class="cmp-grid" style="grid-template-columns:repeat({n}, '
                   f'minmax(128px, 1fr))">{grid}</div></div>'
                   "</div>")
    if sec.colourbar is not None:
        lo, hi = sec.error_range
        out.append('<div class="cbar">' + _img(sec.colourbar, alt="error map colour bar", extra='data-kind="colourbar"')
                   + f'<div class="note">Error maps: log scale from {fmt(lo, 3)} to {fmt(hi, 3)}, shared by every '
                   f"map of this scene (mean of a map = that image's relMSE).</div></div>")
    if sec.flip_colourbar is not None:
        out.append('<div class="cbar">' + _img(sec.flip_colourbar, alt="FLIP map colour bar",
                                               extra='data-kind="colourbar"')
                   + '<div class="note">FLIP maps: linear scale 0 to 1 (mean of a map = that image\'s FLIP).</div>'
                   "</div>")
    return "".join(out)


def _section_html(sec: Section, summary: str = "") -> str:
    out = [f'<section class="card scene" id="{sec.id}" data-scene="{_e(sec.scene)}" '
           f'data-plots="{" ".join(k for k in PLOT_KINDS if k in sec.plots)}" '
           f'data-columns="{_e("|".join(sec.columns))}" '
           f'data-spps="{" ".join(f"{s:g}" for s, _ in sec.image_rows)}">',
           f'<details class="scene-details"><summary><h2>{_e(sec.title)}</h2>'
           f'<span class="note">{_e(summary)}</span></summary>']
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
        et = equal_time_text(sec)
        if et:
            out.append(f'<p class="note">{_e(et)}</p>')
    out.append("<h3>Per-strategy statistics</h3>" + _stats_html(sec))
    if sec.image_rows:
        out.append("<h3>Images at equal spp</h3>" + _images_html(sec))
    out.append("</details></section>")
    return "".join(out)



def _headline_html(entries: list) -> str:
    """The first card: one row per scene, the run's answer (:mod:`reports.headline`)."""
    out = ['<section class="card" id="headline"><h2>The answer: each strategy\'s noise against light sampling, '
           "and our tracer against Mitsuba</h2>"]
    if not entries:
        out.append('<p class="note">summary.json holds no headline yet (a run still going, or one without tail '
                   "references): the sections below show what there is.</p></section>")
        return "".join(out)
    header = headline_header(entries)
    head = []
    for h in header:
        name, _, sub = h.partition(": ")
        head.append(f"<th>{_e(name)}" + (f'<br><span class="sub">{_e(sub)}</span>' if sub else "") + "</th>")
    body = []
    for e, cells in zip(entries, headline_cells(entries)):
        tds = []
        for i, c in enumerate(cells):
            cls = ""
            if i == 1:
                cls = {"pass": "unbiased", "fail": "biased", "undetermined": "nocost"}.get(e.get("verdict"), "")
            tds.append(f'<td class="{cls}">{_e(c)}</td>' if cls else f"<td>{_e(c)}</td>")
        body.append(f'<tr data-scene="{_e(e["scene"])}" data-verdict="{_e(e.get("verdict"))}">{"".join(tds)}</tr>')
    out.append(f'<div class="tablewrap"><table class="data headline" id="headline-table"><thead><tr>{"".join(head)}'
               f'</tr></thead><tbody>{"".join(body)}</tbody></table></div>'
               f'<p class="note">{_e(HEADLINE_NOTE)}</p></section>')
    return "".join(out)


def _direct_grid(spp, cells) -> str:
    """The images of Veach's comparison: a column per technique, ours above Mitsuba's."""
    head = "".join(f"<th>{_e(label)}</th>" for label, _, _ in cells)
    rows = []
    for who, pick in (("ours", 1), ("Mitsuba", 2)):
        tds = []
        for cell in (c[pick] for c in cells):
            shot = "not rendered" if cell is None else (
                _img(cell.png, alt=f"{who} {cell.label}", extra='data-kind="image"')
                + f'<span class="sub">{_e(cell.caption)}</span>')
            tds.append(f"<td>{shot}</td>")
        rows.append(f"<tr><th>{who}</th>{''.join(tds)}</tr>")
    return (f'<div class="tablewrap"><table class="direct-grid"><thead><tr><th>{spp:g} spp</th>{head}</tr></thead>'
            f'<tbody>{"".join(rows)}</tbody></table></div><p class="note">Same exposure for every image; each '
            "column takes the same emitter and BSDF sample counts in both renderers.</p>")


def _direct_html(sections: list[Section]) -> str:
    """Veach's comparison, one card per scene rendered with Mitsuba's ``direct``: the images of
    BSDF sampling, light sampling and MIS at equal spp, ours above Mitsuba's, and their error curves."""
    out = []
    for sec in sections:
        if "direct" not in sec.plots:
            continue
        spp, cells = direct_images(sec)
        png, cap = sec.plots["direct"]
        out.append(f'<section class="card direct" id="direct-{_e(sec.id)}"><h2>{_e(sec.title)}: BSDF sampling, '
                   "light sampling and MIS (Mitsuba's direct integrator)</h2>"
                   f'<div class="plots"><div>{_direct_grid(spp, cells) if cells else ""}</div>'
                   '<figure class="plot">' + _img(png, alt=f"{sec.title} direct comparison plot",
                                                  extra='data-kind="plot" data-plot="direct"')
                   + f"<figcaption>{_e(cap)}</figcaption></figure></div></section>")
    return "".join(out)


def _seed_cells(sections: list[Section]) -> list:
    """The seed figure's images: uniform at SEED_SPP, light at SEED_LIGHT_SPP and the reference,
    from the seed section's image rows (each with its error map), where they were stored."""
    sec = next((s for s in sections if s.scene == SEED_SCENE and s.width == SEED_SIZE and s.height == SEED_SIZE),
               None)
    if sec is None:
        return []
    rows = dict(sec.image_rows)
    want = [(("ours", "uniform"), float(SEED_SPP)), (("ours", "light"), float(SEED_LIGHT_SPP))]
    out = []
    for key, spp in want:
        cell = next((c for c in rows.get(spp, []) if c.key == key and c.png is not None), None)
        if cell is not None:
            out.append((f"{cell.label}, {spp:g} spp", cell))
    ref = next((c for row in rows.values() for c in row if c.key[0] == "reference" and c.png is not None), None)
    if ref is not None:
        out.append(("reference", ref))
    return out


def _seed_html(cmp: dict | None, png: bytes | None, sections: list[Section]) -> str:
    if cmp is None:  # a store without the seed's runs (a custom run): no section at all
        return ""
    lines, rows = seed_lines(cmp)
    out = [f'<section class="card" id="seed" data-present="{"yes" if cmp else "no"}">'
           f"<h2>The seed's comparison: uniform vs light sampling on {SEED_SCENE}, "
           f"{SEED_SIZE}×{SEED_SIZE}</h2>"]
    cells = _seed_cells(sections)
    if cells:
        figs = []
        for label, c in cells:
            shot = _img(c.png, alt=label, cls="seedshot", extra='data-kind="image"')
            figs.append(f'<figure class="seedimg">{shot}'
                        f"<figcaption><b>{_e(label)}</b><br>{_e(c.caption)}</figcaption></figure>")
            if c.err_png is not None:
                figs.append(f'<figure class="seedimg">{_img(c.err_png, alt=f"error map of {label}", cls="err")}'
                            f"<figcaption>error map of {_e(label)}</figcaption></figure>")
        out.append(f'<div class="seedgrid">{"".join(figs)}</div><p class="note">Same exposure for every image; error '
                   "maps: per-pixel relative squared error against the reference on one log colour scale (its bar "
                   "is in the cornell_box 400×400 section below).</p>")
    if png is not None:
        out.append('<div class="plots"><figure class="plot" id="seed-plot">'
                   + _img(png, alt="seed comparison plot", extra='data-kind="plot" data-plot="seed"')
                   + f"<figcaption>Median {cmp['label']} over seeds with min-max band; diamonds: uniform's error at "
                   f"{SEED_SPP} spp and where light sampling reaches it.</figcaption></figure><div>")
    out.append("".join(f'<p class="big">{_e(s)}</p>' for s in lines))
    if rows:
        out.append(f'<table class="data" style="width:auto"><thead><tr><th>spp</th><th>uniform {_e(cmp["label"])}</th>'
                   f"<th>light {_e(cmp['label'])}</th></tr></thead><tbody>"
                   + "".join("<tr>" + "".join(f"<td>{_e(c)}</td>" for c in r) + "</tr>" for r in rows)
                   + '</tbody></table><p class="note">Median over seeds.</p>')
    if png is not None:
        out.append("</div></div>")
    out.append("</section>")
    return "".join(out)


def _scene_summary(sec: Section, entries: list) -> str:
    """One line beside a collapsed section's title: its verdict, from the headline."""
    e = next((e for e in entries if (e["scene"], e.get("width"), e.get("height")) == (sec.scene, sec.width,
                                                                                          sec.height)), None)
    return f"ours vs reference: {verdict_text(e)}" if e else ""


def page_html(store: Store, sections: list[Section], cmp, seed_png, problems: list, *, metric: str = "relmse") -> str:
    """The whole ``index.html``: run facts, sections, seed comparison (when the store has it), definitions, problems."""
    facts = facts_table(store.meta, n_records=len(store.records), n_raw=store.n_raw_records,
                        records=store.records)
    entries = headline_entries(store)
    title = f"rtbench report — {store.path.name}"
    toc = '<a href="#headline">answer</a>' + ('<a href="#seed">seed comparison</a>' if cmp is not None else "")
    toc += f'<a href="#{sections[0].id}">scenes ({len(sections)})</a>' if sections else ""
    toc += '<a href="#facts">run facts</a><a href="#formulas">definitions</a>'
    if problems:
        toc += '<a href="#problems">problems</a>'
    preset = store.meta.get("preset") or "?"
    out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
           '<meta name="viewport" content="width=device-width, initial-scale=1">',
           f"<title>{_e(title)}</title><style>{CSS}</style></head><body>",
           f'<header class="top"><h1>{_e(title)}</h1><div class="sub">How much noisier is each sampling strategy '
           "than light sampling, at equal samples and at equal time, and does our tracer agree with Mitsuba 3? "
           f"Preset {_e(preset)}, {len(sections)} scene section(s), {len(store.records)} job records; one error "
           f"metric throughout: {_e(SPECS[metric].label)}.</div></header>",
           f'<nav class="toc">{toc}</nav><main>', _headline_html(entries), _direct_html(sections),
           _seed_html(cmp, seed_png, sections),
           '<p class="note">Per scene and size below (click to open): convergence plots, per-strategy statistics '
           "and images at equal spp.</p>"]
    out += [_section_html(s, _scene_summary(s, entries)) for s in sections]
    out.append('<section class="card" id="facts"><h2>Run facts</h2><table class="facts">'
               + "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in facts) + "</table></section>")
    out.append('<section class="card" id="formulas"><h2>Metric definitions</h2><dl class="formulas">'
               + "".join(f"<dt>{_e(k)}</dt><dd>{_e(v)}</dd>" for k, v in FORMULAS) + "</dl></section>")
    if problems:
        out.append('<section class="card" id="problems"><h2>Problems found in the store</h2><ul class="problems">'
                   + "".join(f"<li>{_e(p)}</li>" for p in problems) + "</ul></section>")
    out.append(f"</main><footer>Generated by rtbench reports on "
               f"{_e(timestamp(offset=False))} from {_e(store.path)}.</footer>"
               f"<script>{JS}</script></body></html>")
    return "\n".join(out)
