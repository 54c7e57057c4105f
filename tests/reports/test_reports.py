"""Tests of ``reports``: a synthetic results store -> index.html + summary.md, checked as data and in a browser."""
from __future__ import annotations

import base64
import io
import json
import math
import os
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from report_store import make_store

import reports  # noqa: E402
from benchmarks.metrics import view  # noqa: E402
from reports.build import _chromium as find_chromium  # noqa: E402
from reports.curves import curves, loglog_interp, loglog_slope, seed_comparison  # noqa: E402
from benchmarks.display import reference_exposure  # noqa: E402
from reports.images import error_map, pick_spps  # noqa: E402
from reports.store import load_store  # noqa: E402

SCENES = ("cornell_box", "spheres")
STRATEGIES = ("uniform", "light", "mixture")
SPPS = (1, 4, 16, 64)  # four budgets: the fewest a slope is fitted to
SEEDS = (0, 1)
COLUMNS = ["uniform", "light", "mixture", "Mitsuba path", "reference"]


# ----------------------------------------------------------------------------------------- helpers

class _Page(HTMLParser):
    """Collects every element as (tag, attrs, ancestors' ids/classes) and the text of table cells."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.elements = []
        self.stack = []
        self.tables = {}
        self._table = None
        self._cell = None
        self._row = None
        self.doctype = None

    def handle_decl(self, decl):
        self.doctype = decl

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.elements.append((tag, a, [dict(x[1]) for x in self.stack]))
        if tag not in ("img", "meta", "br", "hr", "input", "link"):
            self.stack.append((tag, a))
        if tag == "table" and a.get("id"):
            self._table = a["id"]
            self.tables[self._table] = []
        elif tag == "tr" and self._table:
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._cell = []

    def handle_endtag(self, tag):
        while self.stack:
            t, _ = self.stack.pop()
            if t == tag:
                break
        if tag in ("td", "th") and self._cell is not None:
            self._row.append("".join(self._cell).strip())
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self.tables[self._table].append(self._row)
            self._row = None
        elif tag == "table":
            self._table = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def _parse(path: Path) -> _Page:
    p = _Page()
    p.feed(path.read_text(encoding="utf-8"))
    p.close()
    return p


def _png_size(src: str) -> tuple[int, int]:
    from PIL import Image

    assert src.startswith("data:image/png;base64,"), src[:60]
    im = Image.open(io.BytesIO(base64.b64decode(src.split(",", 1)[1], validate=True)))
    im.load()
    assert im.format == "PNG"
    return im.size


def _md_tables(md: str) -> dict[str, list[list[str]]]:
    """Markdown tables keyed by the ``## heading`` above them (first table of each heading), as a
    Markdown reader shows them: backslash escapes and entities undone."""
    import html as _html

    def shown(text: str) -> str:
        return _html.unescape(re.sub(r"\\(.)", r"\1", text))

    out, heading, rows = {}, None, None
    for line in md.splitlines() + [""]:
        if line.startswith("## "):
            heading, rows = shown(line[3:].strip()), None
        elif line.startswith("|"):
            cells = [shown(c.strip()) for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
            if rows is None:
                rows = []
            if not all(re.fullmatch(r"-+", c) for c in cells):
                rows.append(cells)
        elif rows is not None:
            out.setdefault(heading, rows)
            rows = None
    return out


def _numbers(cell: str) -> list[float]:
    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e[+-]?\d+)?", cell)]


def _close(printed: float, value: float) -> bool:
    """A number printed to 4 significant digits equals the stored value."""
    return math.isclose(printed, value, rel_tol=6e-4, abs_tol=1e-300)


# ----------------------------------------------------------------------------------------- fixtures

@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    return make_store(tmp_path_factory.mktemp("store"), scenes=SCENES, strategies=STRATEGIES, spps=SPPS,
                      seeds=SEEDS, size=16, duplicate=True, truncated=True, seed_comparison=True)


@pytest.fixture(scope="module")
def report(store, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("report")
    page = reports.build_report(store, out=out)
    assert page == out / "index.html"
    return page


# ----------------------------------------------------------------------------------------- store

def test_load_store_dedupes_last_wins_and_skips_truncated_line(store):
    st = load_store(store)
    n_expected = len(SCENES) * (len(STRATEGIES) + 1) * len(SPPS) * len(SEEDS) + 2 * 5 * len(SEEDS)
    assert len(st.records) == n_expected
    assert st.n_raw_records == n_expected + 1  # one stale duplicate, truncated line not counted
    first = [r for r in st.records if (r["scene"], r["renderer"], r["strategy"], r["spp"], r["seed"])
             == ("cornell_box", "ours", "uniform", 1, 0) and r["width"] == 16]
    assert len(first) == 1 and first[0]["rmse"] != 999.0  # the stale copy (rmse 999) lost
    assert any("truncated" in p for p in st.problems)
    assert any("duplicate" in p for p in st.problems)
    assert st.sections()[0] == ("cornell_box", 16, 16)  # the full sweep before the 400x400 seed runs
    assert set(st.sections()) == {("cornell_box", 16, 16), ("cornell_box", 400, 400), ("spheres", 16, 16)}


def test_rows_without_size_join_their_scenes_only_section(tmp_path):
    st = make_store(tmp_path / "s", scenes=("spheres",), strategies=("mis",), spps=(1, 2), seeds=(0,), size=8,
                    duplicate=False)
    summ = json.loads((st / "summary.json").read_text())
    for r in summ["rows"]:
        r["width"] = r["height"] = None
    (st / "summary.json").write_text(json.dumps(summ))
    loaded = load_store(st)
    assert loaded.sections() == [("spheres", 8, 8)]
    assert [r["strategy"] for r in loaded.section_rows("spheres", 8, 8)] == ["mis", "path"]


def test_load_store_rejects_what_is_not_a_store(tmp_path):
    with pytest.raises(ValueError, match="not a folder"):
        load_store(tmp_path / "nope")
    with pytest.raises(ValueError, match="neither results.jsonl nor summary.json"):
        load_store(tmp_path)
    # lines that are not job records are skipped and listed, as `rtbench run` skips them (issue 15 case 7)
    (tmp_path / "results.jsonl").write_text('{"renderer": "ours", "strategy": "mis", "spp": 4}\n{"x": 1}\n')
    st = load_store(tmp_path)
    assert not st.records and "results.jsonl: line 1 is not a job record (no scene); skipped" in st.problems
    (tmp_path / "results.jsonl").write_text('{"scene": "a", "renderer": "ours", "strategy": "mis", "spp": 0}\n')
    st = load_store(tmp_path)
    assert not st.records and any("'spp' must be a positive number" in p for p in st.problems)
    (tmp_path / "results.jsonl").write_text('not json\n{"scene": "a", "renderer": "ours", "strategy": "mis", '
                                            '"spp": 1}\n')
    st = load_store(tmp_path)  # a corrupt middle line is skipped and reported, as the harness's reader does
    assert len(st.records) == 1 and "results.jsonl: line 1 is not valid JSON; skipped" in st.problems


def test_build_report_rejects_a_file_as_output(store, tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(ValueError, match="not a folder"):
        reports.build_report(store, out=f)


@pytest.mark.parametrize("fmt", ["svg", "pdf"])
def test_build_report_refuses_a_plots_link_out_of_its_folder(store, tmp_path, fmt):
    """A received store's plots/ may be a link elsewhere: the report refuses it before writing
    anything (was: the plot files written into the link's target)."""
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / "plots").symlink_to(elsewhere)
    with pytest.raises(ValueError, match="is a symbolic link or not a folder"):
        reports.build_report(store, out=out, formats=("html", fmt))
    assert list(elsewhere.iterdir()) == [] and not (out / "index.html").exists()


# ----------------------------------------------------------------------------------------- numerics

def test_seed_comparison_matches_power_laws(store):
    cmp = seed_comparison(load_store(store).records)
    # relMSE (the report's metric, reference noise removed): uniform 0.75/spp, light 0.03/spp: light
    # matches uniform@50 at 50 * 0.03/0.75 = 2 spp
    assert cmp["label"] == "relMSE"
    assert cmp["target_exact"] and math.isclose(cmp["target_rmse"], 0.75 / 50, rel_tol=1e-12)
    assert cmp["method"] == "interpolated"
    assert math.isclose(cmp["light_spp"], 2.0, rel_tol=1e-9)
    assert math.isclose(cmp["saving"], 25.0, rel_tol=1e-9)
    assert math.isclose(cmp["light_slope"], -1.0, rel_tol=1e-9)


def test_seed_comparison_absent_and_already_below():
    assert seed_comparison([]) is None
    recs = [{"scene": "cornell_box", "renderer": "ours", "strategy": s, "spp": n, "seed": 0, "width": 400,
             "height": 400, "relmse": a / n, "seconds": 1.0}
            for s, a in (("uniform", 0.5), ("light", 0.0001)) for n in (4, 16, 50)]
    cmp = seed_comparison(recs)
    # light at 4 spp is already below uniform@50: never extrapolated (a biased curve's slope
    # says nothing of smaller budgets), "at most" its smallest budget
    assert cmp["method"] == "at most" and cmp["light_spp"] == 4.0 and cmp["saving"] == 12.5
    wrong_size = [dict(r, width=64, height=64) for r in recs]
    assert seed_comparison(wrong_size) is None


def test_curves_loglog_and_error_map():
    recs = [{"renderer": "ours", "strategy": "mis", "spp": n, "seed": k, "rmse": (1 + k) / math.sqrt(n),
             "seconds": n * (1 + k)} for n in (1, 4, 16) for k in (0, 1, 2)]
    recs.append({"renderer": "mitsuba", "strategy": "path", "spp": 1, "seed": 0, "rmse": None, "seconds": 1})
    (c,) = curves(recs, "rmse")  # Mitsuba has no finite value: left out
    assert c.spp.tolist() == [1, 4, 16]
    assert np.allclose(c.median, 2 / np.sqrt(c.spp)) and np.allclose(c.lo, 1 / np.sqrt(c.spp))
    assert np.allclose(c.hi, 3 / np.sqrt(c.spp)) and np.allclose(c.seconds, 2 * c.spp)
    assert math.isclose(loglog_slope(c.spp, c.median), -0.5, rel_tol=1e-12)
    assert math.isclose(loglog_interp([1, 4], [1.0, 0.5], 2), 1 / math.sqrt(2), rel_tol=1e-12)
    assert math.isnan(loglog_interp([1, 4], [1.0, 0.5], 8))
    rng = np.random.default_rng(0)
    ref = rng.random((8, 9, 3)).astype(np.float32)
    img = ref + rng.normal(0, 0.1, ref.shape).astype(np.float32)
    want = np.mean((img.astype(np.float64) - ref) ** 2 / (ref.astype(np.float64) ** 2 + 0.01))
    assert math.isclose(float(error_map(img, ref).mean()), want, rel_tol=1e-9)
    with pytest.raises(ValueError, match="differ in shape"):
        error_map(img[:4], ref)
    ref2 = np.full((10, 10, 3), 0.25, np.float32)
    assert math.isclose(reference_exposure(ref2), 2.0, rel_tol=1e-6)  # 0.25 * 2**2 = 1: white
    assert reference_exposure(np.zeros((4, 4, 3))) == 0.0
    assert pick_spps([1, 2, 4, 8, 16, 32, 64]) == [4.0, 16.0, 64.0]
    assert pick_spps([1, 2, 8, 32, 128]) == [1.0, 8.0, 128.0]


# ----------------------------------------------------------------------------------------- HTML

def test_html_parses_and_embeds_every_promised_plot_and_image(report):
    page = _parse(report)
    assert page.doctype and page.doctype.lower() == "doctype html"
    ids = [a["id"] for _, a, _ in page.elements if "id" in a]
    assert len(ids) == len(set(ids)), "duplicate element ids"
    ids = set(ids)
    # self-contained: no network, no external files
    for tag, a, _ in page.elements:
        for attr in ("src", "href"):
            v = a.get(attr)
            if v is None:
                continue
            assert not re.match(r"^(https?:|//|file:)", v), f"<{tag} {attr}={v[:60]}> leaves the page"
            if attr == "href":
                assert v.startswith("#") and v[1:] in ids, f"dangling link {v}"
            if attr == "src":
                assert v.startswith("data:image/png;base64,"), f"<{tag}> src is not embedded"
        assert tag not in ("link", "iframe"), f"unexpected <{tag}>"
    imgs = [(a, anc) for t, a, anc in page.elements if t == "img"]
    assert imgs and all(_png_size(a["src"])[0] > 0 for a, _ in imgs)

    sections = {a["data-scene"]: a for t, a, _ in page.elements if t == "section" and "data-scene" in a}
    assert set(sections) == set(SCENES)
    for scene in SCENES:
        sec = [a for t, a, _ in page.elements if t == "section" and a.get("id") == f"scene-{scene.replace('_', '-')}-16-16"]
        assert sec, f"no section for {scene} 16x16"
        sid = sec[0]["id"]
        assert sec[0]["data-plots"].split() == ["relmse", "time"]  # one metric: its convergence and time plots
        assert sec[0]["data-columns"].split("|") == COLUMNS
        assert sec[0]["data-spps"].split() == ["4", "16", "64"]
        inside = [(a, anc) for a, anc in imgs if any(x.get("id") == sid for x in anc)]
        plots = {a["data-plot"] for a, _ in inside if a.get("data-kind") == "plot"}
        assert plots == {"relmse", "time"}
        for spp in ("4", "16", "64"):
            shots = {a["data-column"] for a, _ in inside if a.get("data-kind") == "image" and a["data-spp"] == spp}
            errs = {a["data-column"] for a, _ in inside if a.get("data-kind") == "error" and a["data-spp"] == spp}
            assert shots == set(COLUMNS), (scene, spp, shots)
            assert errs == set(COLUMNS) - {"reference"}, (scene, spp, errs)
            flips = {a["data-column"] for a, _ in inside if a.get("data-kind") == "flip" and a["data-spp"] == spp}
            assert flips == set(COLUMNS) - {"reference"}, (scene, spp, flips)  # FLIP maps in the image grid
        assert sum(a.get("data-kind") == "colourbar" for a, _ in inside) == 2  # relative error and FLIP
        sizes = {_png_size(a["src"]) for a, _ in inside if a.get("data-kind") in ("image", "error", "flip")}
        assert sizes == {(16, 16)}
    # the flip and zoom wiring point at elements that exist
    wraps = [a for t, a, _ in page.elements if t == "div" and "shotwrap" in a.get("class", "")]
    assert wraps
    for a in wraps:
        assert a["data-zoom"] in ids
        if "is-ref" not in a["class"]:
            assert a["data-ref"] in ids and a["data-ref"].startswith("ref-")
    # the seed comparison section is present with its plot
    seed = [a for t, a, _ in page.elements if t == "section" and a.get("id") == "seed"]
    assert seed and seed[0]["data-present"] == "yes"
    assert any(a.get("data-plot") == "seed" for a, _ in imgs)


def test_html_and_markdown_tables_hold_the_stores_numbers(store, report):
    rows = json.loads((store / "summary.json").read_text())["rows"]
    md = (report.parent / "summary.md").read_text()
    tables = _md_tables(md)
    page = _parse(report)
    checked = 0
    for scene in SCENES:
        md_rows = tables[f"{scene} (16×16)"]
        header, body = md_rows[0], md_rows[1:]
        html_rows = page.tables[f"scene-{scene.replace('_', '-')}-16-16-table"]
        assert [c.strip() for c in html_rows[0]] == [h.strip() for h in header]
        assert [r[1:] for r in html_rows[1:]] == [r[1:] for r in body]  # same numbers in HTML and Markdown
        col = {h: i for i, h in enumerate(header)}
        srows = [r for r in rows if r["scene"] == scene]
        assert len(body) == len(srows) == len(STRATEGIES) + 1
        for raw in srows:
            r = view(raw, "relmse")  # the report's default metric
            label = r["strategy"] if r["renderer"] == "ours" else "Mitsuba path"
            (cells,) = [b for b in body if b[0] == label]
            slope, lo, hi, first, last = _numbers(cells[col["relMSE slope [95% CI]"]].replace("–", " "))[:5]
            assert math.isclose(slope, r["slope"], rel_tol=6e-3) and math.isclose(lo, r["slope_ci"][0], rel_tol=6e-3)
            assert (first, last) == tuple(r["slope_range"])  # the budgets fitted are printed
            assert cells[col["bias test"]] == r["bias_verdict"]  # the same words as the CSV and the console
            pct = _numbers(cells[col["bias [95% CI]"]].replace("−", "-"))
            assert math.isclose(pct[0], 100 * r["relative_bias"], abs_tol=0.06)
            (p,) = _numbers(cells[col["p"]])
            assert math.isclose(p, r["bias_p"], rel_tol=0.06)
            noise = cells[col["noise vs light: equal spp / equal time"]]
            if r["strategy"] == "light":
                assert noise == "baseline"
            else:
                at_spp, at_time = noise.split(" / ")
                assert math.isclose(_numbers(at_spp)[0], r["noise_vs_light"], rel_tol=0.01)
                assert math.isclose(_numbers(at_time)[0], r["time_noise_vs_light"], rel_tol=0.01)
            for name, key in (("efficiency / Mitsuba (relMSE)", "efficiency_vs_mitsuba"),
                              ("time to target (s)", "time_to_target"),
                              ("samples/s", "samples_per_second"),
                              ("samples/s / Mitsuba", "samples_per_second_vs_mitsuba")):
                cell = cells[col[name]]
                if r["bias_significant"] and key in ("efficiency_vs_mitsuba", "time_to_target"):
                    assert cell == "biased", (name, cell)  # no efficiency for a biased estimator
                elif r[key] is None:
                    assert cell == "–", (name, cell)
                else:
                    (v,) = _numbers(cell)
                    assert math.isclose(v, r[key], rel_tol=6e-3), (scene, label, name, cell, r[key])
                checked += 1
    assert checked == len(SCENES) * (len(STRATEGIES) + 1) * 4
    # run facts and formulas
    assert "Synthetic CPU @ 3.0GHz, 2 cores" in md and "3.9.1 (llvm_ad_rgb)" in md and "| preset | test |" in md
    assert "eps = 0.01" in md and "sigma=1.5" in md
    assert re.search(r"Light sampling reaches that relMSE at about 2 spp .*25× fewer samples", md)
    # the answer comes first: the headline table, one row per scene, before any section
    assert md.index("## The answer") < md.index("## Seed comparison") < md.index(f"## {SCENES[0]} (16×16)")
    answer = tables["The answer"]
    assert [row[0] for row in answer[1:]] == [f"{sc} 16×16" for sc in SCENES]
    assert all(row[1] == "–" for row in answer[1:])  # the synthetic store has no mis curve: no verdict


def test_report_degrades_without_meta_and_summary(store, tmp_path):
    st = tmp_path / "partial"
    shutil.copytree(store, st)
    (st / "meta.json").unlink()
    (st / "summary.json").unlink()
    page = reports.build_report(st)
    assert page == st / "index.html" and (st / "summary.md").exists()
    text = page.read_text()
    assert "meta.json is missing" in text and "summary.json is missing" in text
    assert "summary.json holds no rows for this scene and size." in text
    assert "names no reference image" in text  # no meta: no reference, images shown without error maps
    p = _parse(page)
    assert any(a.get("data-plot") == "relmse" for t, a, _ in p.elements if t == "img")
    assert any(a.get("data-kind") == "image" for t, a, _ in p.elements if t == "img")
    assert not any(a.get("data-kind") == "error" for t, a, _ in p.elements if t == "img")


def test_custom_report_has_no_stale_seed_comparison_section(tmp_path):
    # issue 16: every custom report carried "seed comparison ... not reproduced here"
    st = make_store(tmp_path / "s", scenes=("spheres",), strategies=("mis",), spps=(1, 2), seeds=(0,),
                    size=8, seed_comparison=False, duplicate=False)
    page = reports.build_report(st)
    for text in (page.read_text(), (st / "summary.md").read_text()):
        assert "not reproduced here" not in text and "Seed comparison" not in text
        assert 'id="seed"' not in text and 'href="#seed"' not in text


def test_cli_report_and_summary_table(store, tmp_path, capsys):
    from benchmarks.cli import main

    out = tmp_path / "cli"
    assert main(["report", str(store), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"report: {(out / 'index.html').resolve()}" in printed
    assert (out / "index.html").exists() and (out / "summary.md").exists()
    assert "fail" in printed and "Mitsuba path" in printed and "light reaches it at ~2 spp" in printed
    table = reports.summary_table(store)
    lines = [ln for ln in table.splitlines() if ln.startswith(("cornell_box", "spheres"))]
    assert len(lines) == len(SCENES) * (len(STRATEGIES) + 1)
    assert all((" fail " in ln) == (" light " in ln) for ln in lines)  # the page's verdict words
    assert main(["report", str(tmp_path / "missing")]) == 2  # bad input: one clear line, exit 2
    assert "is not a folder" in capsys.readouterr().err


# ----------------------------------------------------------------------------------------- browser

_CHECK = r"""
<script>
(function () {
  var errs = [];
  window.addEventListener("error", function (e) { errs.push("error: " + e.message); });
  var ce = console.error, cw = console.warn;
  console.error = function () { errs.push("console.error: " + Array.prototype.join.call(arguments, " ")); };
  console.warn = function () { errs.push("console.warn: " + Array.prototype.join.call(arguments, " ")); };
  window.__rtbench_errs = errs;
})();
</script>
"""

_PROBE = r"""
<script>
window.addEventListener("load", function () {
  // the scene sections are collapsed: open them all, as a reader does, before probing
  Array.prototype.forEach.call(document.querySelectorAll("details"), function (d) { d.open = true; });
  var r = {errors: window.__rtbench_errs};
  var imgs = Array.prototype.slice.call(document.images);
  r.images = imgs.length;
  r.broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); }).length;
  var plots = imgs.filter(function (i) { return i.getAttribute("data-kind") === "plot"; });
  r.plots = plots.length;
  r.plots_loaded = plots.filter(function (i) {
    return i.complete && i.naturalWidth >= 200 && i.naturalHeight >= 150 && i.getBoundingClientRect().width > 100;
  }).length;
  r.flipmaps = imgs.filter(function (i) { return i.getAttribute("data-kind") === "flip" && i.naturalWidth > 0; }).length;
  var cs = Array.prototype.slice.call(document.querySelectorAll("canvas.zoom"));
  r.canvases = cs.length;
  r.drawn = cs.filter(function (c) {
    var d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data, lo = 255, hi = 0;
    for (var i = 0; i < d.length; i += 4) { lo = Math.min(lo, d[i + 1]); hi = Math.max(hi, d[i + 1]); }
    return d[3] > 0 && hi > lo;
  }).length;
  var w = document.querySelector(".shotwrap:not(.is-ref)"), img = w.querySelector("img.shot");
  var ref = document.getElementById(w.getAttribute("data-ref")), own = img.src;
  w.click();
  r.flip = img.src === ref.src && w.classList.contains("flipped") && own !== ref.src;
  w.click();
  r.unflip = img.src === own && !w.classList.contains("flipped");
  w.dispatchEvent(new MouseEvent("mouseenter"));
  document.dispatchEvent(new KeyboardEvent("keydown", {key: "r"}));
  r.keyflip = img.src === ref.src;
  document.dispatchEvent(new KeyboardEvent("keydown", {key: "Escape"}));
  r.escape = img.src === own;
  document.dispatchEvent(new KeyboardEvent("keydown", {key: "+"}));
  r.zoomlabel = document.querySelector(".zoomlevel").textContent;
  // zoom: moving the pointer over an image moves the crop of every column of its row
  var row = w.closest(".cmp-row"), rect = img.getBoundingClientRect();
  var canvases = Array.prototype.slice.call(row.querySelectorAll("canvas.zoom"));
  function sig(c) {
    var d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data, s = 0;
    for (var i = 0; i < d.length; i += 4) s = (s * 31 + d[i] + 7 * d[i + 1] + 13 * d[i + 2]) % 1000000007;
    return s;
  }
  function move(fx, fy) {
    w.dispatchEvent(new MouseEvent("mousemove", {clientX: rect.left + fx * rect.width,
                                                 clientY: rect.top + fy * rect.height, bubbles: true}));
    return {sigs: canvases.map(sig), box: w.querySelector(".cropbox").style.left + "," +
            w.querySelector(".cropbox").style.top};
  }
  var a = move(0.05, 0.05), b = move(0.95, 0.95);
  r.zoom_moves = canvases.length > 1 && a.box !== b.box &&
    a.sigs.every(function (s, i) { return s !== b.sigs[i]; });
  r.zooming = row.classList.contains("zooming");
  document.dispatchEvent(new KeyboardEvent("keydown", {key: "-"}));
  document.dispatchEvent(new KeyboardEvent("keydown", {key: "-"}));
  r.zoomout = document.querySelector(".zoomlevel").textContent;
  document.body.setAttribute("data-check", JSON.stringify(r));
});
</script>
"""


_LAYOUT = r"""
<script>
window.addEventListener("load", function () {
  Array.prototype.forEach.call(document.querySelectorAll("details"), function (d) { d.open = true; });
  var inner = window.innerWidth, bad = [];
  function scrolls(e) {  // inside a horizontally scrolling box (the wide tables) is fine
    for (var p = e.parentElement; p; p = p.parentElement) {
      var o = getComputedStyle(p).overflowX;
      if (o === "auto" || o === "scroll" || o === "hidden") return true;
    }
    return false;
  }
  Array.prototype.forEach.call(document.querySelectorAll("body *"), function (e) {
    var r = e.getBoundingClientRect();
    if (r.width > 0 && r.right > inner + 1 && !scrolls(e) && bad.length < 5)
      bad.push(e.tagName + "." + e.className + " in " + e.parentElement.tagName + "." +
               e.parentElement.className + " '" + (e.textContent || "").slice(0, 30) + "' right=" + Math.round(r.right));
  });
  var plots = Array.prototype.map.call(document.querySelectorAll("figure.plot img"),
                                       function (i) { return i.getBoundingClientRect().width; });
  var fonts = Array.prototype.map.call(document.querySelectorAll("p, td, th, figcaption, .cap"),
                                       function (e) { return parseFloat(getComputedStyle(e).fontSize); });
  document.body.setAttribute("data-layout", JSON.stringify({
    inner: inner, scroll: document.documentElement.scrollWidth, overflowing: bad,
    min_plot: Math.min.apply(null, plots), min_font: Math.min.apply(null, fonts)}));
});
</script>
"""


@pytest.fixture(scope="session")
def chromium():
    """Debian's chromium; installed with apt-get when missing and running as root, else the test is skipped."""
    exe = find_chromium()
    if exe is None and hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("apt-get") \
            and os.environ.get("RTBENCH_NO_APT") != "1":
        env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
        cmd = ["apt-get", "install", "-y", "-q", "--no-install-recommends", "chromium", "fonts-liberation",
               "fonts-dejavu-core"]
        try:
            if subprocess.run(cmd, env=env, capture_output=True, timeout=900).returncode != 0:
                subprocess.run(["apt-get", "update", "-q"], env=env, capture_output=True, timeout=600)
                subprocess.run(cmd, env=env, capture_output=True, timeout=900)
        except (OSError, subprocess.TimeoutExpired):
            pass
        exe = find_chromium()
    if exe is None:
        pytest.skip("no chromium: install it with `apt-get install -y --no-install-recommends chromium "
                    "fonts-liberation fonts-dejavu-core` (the test does so itself only "
                    "as root with apt-get available)")
    return exe


def _chromium(exe, tmp_path, *args, timeout=120):
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--hide-scrollbars",
           "--disable-extensions", "--mute-audio", f"--user-data-dir={tmp_path / 'profile'}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def test_page_in_headless_chromium(chromium, report, tmp_path):
    # 1. the page as written: no console message of any kind (the page logs nothing when all is well)
    url = report.resolve().as_uri()
    res = _chromium(chromium, tmp_path, "--enable-logging=stderr", "--v=0", "--virtual-time-budget=3000",
                    "--dump-dom", url)
    assert res.returncode == 0, res.stderr[-2000:]
    console = [ln for ln in res.stderr.splitlines() if "CONSOLE" in ln and report.name in ln]
    assert console == [], console
    assert 'class="cmp-row' in res.stdout  # the DOM was built

    # 2. an instrumented copy: errors caught in-page, images decoded, zoom canvases drawn, flip and keys work
    probe = tmp_path / "probe.html"
    text = report.read_text(encoding="utf-8")
    probe.write_text(text.replace("<head>", "<head>" + _CHECK, 1).replace("</body>", _PROBE + "</body>", 1),
                     encoding="utf-8")
    res = _chromium(chromium, tmp_path, "--virtual-time-budget=3000", "--dump-dom", probe.as_uri())
    m = re.search(r'data-check="([^"]*)"', res.stdout)
    assert m, res.stderr[-2000:]
    import html as _html

    check = json.loads(_html.unescape(m.group(1)))
    assert check["errors"] == []
    assert check["images"] > 40 and check["broken"] == 0
    assert check["canvases"] > 0 and check["drawn"] == check["canvases"]
    assert check["flip"] and check["unflip"] and check["keyflip"] and check["escape"]
    assert check["zoomlabel"] == "×8"
    # every plot the sections promise (data-plots) and the seed plot loads; FLIP maps decode
    promised = sum(len(p.split()) for p in re.findall(r'data-plots="([^"]*)"', text)) + 1
    assert promised >= 2 * len(SCENES) + 1
    assert check["plots"] == promised and check["plots_loaded"] == promised
    assert check["flipmaps"] > 0
    # zoom follows the pointer in every column of the row; - and + change the zoom
    assert check["zoom_moves"] and check["zooming"] and check["zoomout"] == "×2"

    # 3. a screenshot that is not blank
    from PIL import Image

    shot = tmp_path / "shot.png"
    res = _chromium(chromium, tmp_path, "--window-size=1400,2600", f"--screenshot={shot}", url)
    assert shot.exists(), res.stderr[-2000:]
    a = np.asarray(Image.open(shot).convert("RGB"), dtype=np.float64)
    assert a.shape[:2] == (2600, 1400)
    assert a.std() > 20, "screenshot is (nearly) uniform"
    assert len(np.unique(a.reshape(-1, 3).astype(np.uint8), axis=0)) > 1000
    keep = os.environ.get("RTBENCH_REPORT_SCREENSHOT")
    if keep:
        shutil.copy(shot, keep)

    # 4. layout at a desktop width and at phone width: nothing wider than the window. Headless
    # windows are at least 500 px wide, so the phone is an iframe of 390 px in a 1400 px window.
    lay = tmp_path / "layout.html"
    lay.write_text(text.replace("</body>", _LAYOUT + "</body>", 1), encoding="utf-8")
    for width, height in ((1400, 900), (390, 844)):
        frame = tmp_path / f"frame{width}.html"
        frame.write_text(f'<!DOCTYPE html><html><body style="margin:0"><iframe id="f" src="{lay.name}" '
                         f'style="border:0;width:{width}px;height:{height}px"></iframe><script>'
                         'window.addEventListener("load", function () { document.body.setAttribute("data-layout", '
                         'document.getElementById("f").contentDocument.body.getAttribute("data-layout")); });'
                         "</script></body></html>", encoding="utf-8")
        res = _chromium(chromium, tmp_path, "--window-size=1400,900", "--virtual-time-budget=3000",
                        "--allow-file-access-from-files", "--dump-dom", frame.as_uri())
        m = re.search(r'data-layout="([^"]*)"', res.stdout)
        assert m, res.stderr[-2000:]
        layout = json.loads(_html.unescape(m.group(1)))
        assert layout["inner"] == width, layout
        assert layout["scroll"] <= layout["inner"], f"horizontal overflow at {width} px: {layout}"
        assert layout["overflowing"] == [], layout
        assert layout["min_plot"] > 0.8 * min(520, width - 60), layout  # plots stay readable
        assert layout["min_font"] >= 10, layout


_FIRST_SCREEN = r"""
<script>
window.addEventListener("load", function () {
  var h = window.innerHeight, r = {};
  var t = document.getElementById("headline-table");
  r.table = !!t;
  r.table_top = t ? t.getBoundingClientRect().top : -1;
  r.table_bottom = t ? t.getBoundingClientRect().bottom : -1;
  r.rows = t ? Array.prototype.map.call(t.querySelectorAll("tbody tr"), function (tr) {
    return tr.getAttribute("data-scene"); }) : [];
  r.text = t ? t.textContent : "";
  var seed = Array.prototype.slice.call(document.querySelectorAll("#seed .seedgrid img"));
  r.seed_images = seed.map(function (i) { return i.getAttribute("alt"); });
  r.seed_first_top = seed.length ? seed[0].getBoundingClientRect().top : -1;
  r.seed_loaded = seed.every(function (i) { return i.complete && i.naturalWidth > 0; });
  r.page = document.body.textContent;
  r.window = h;
  document.body.setAttribute("data-first", JSON.stringify(r));
});
</script>
"""


def test_first_screen_answers_the_question(chromium, report, tmp_path):
    """The page opens on its answer: the headline table (a row per scene, no NaN) and the seed
    figure (uniform at 50 spp, light at 4 spp, the reference, error maps) on the first screen
    of a 1400 x 900 window; nowhere the stale "not 400x400" note of the seed section."""
    import html as _html

    probe = tmp_path / "first.html"
    probe.write_text(report.read_text(encoding="utf-8").replace("</body>", _FIRST_SCREEN + "</body>", 1),
                     encoding="utf-8")
    res = _chromium(chromium, tmp_path, "--window-size=1400,900", "--virtual-time-budget=3000", "--dump-dom",
                    probe.as_uri())
    m = re.search(r'data-first="([^"]*)"', res.stdout)
    assert m, res.stderr[-2000:]
    first = json.loads(_html.unescape(m.group(1)))
    assert first["table"] and first["rows"] == list(SCENES)
    assert 0 < first["table_top"] < first["table_bottom"] < first["window"]  # on the first screen, whole
    assert "nan" not in first["text"].lower() and "inf" not in first["text"].lower()
    assert first["seed_images"][:2] == ["uniform, 50 spp", "error map of uniform, 50 spp"]
    assert "light, 4 spp" in first["seed_images"] and "reference" in first["seed_images"]
    assert first["seed_loaded"] and first["seed_first_top"] < first["window"]
    assert "not 400" not in first["page"]
    from PIL import Image

    shot = tmp_path / "first.png"
    _chromium(chromium, tmp_path, "--window-size=1400,900", f"--screenshot={shot}", report.resolve().as_uri())
    a = np.asarray(Image.open(shot).convert("RGB"), dtype=np.float64)
    assert a.std() > 20 and len(np.unique(a.reshape(-1, 3).astype(np.uint8), axis=0)) > 1000


# ----------------------------------------------------------------------------------------- formats (issue 16)

def test_report_formats_write_vector_plots_and_tidy_csvs(store, tmp_path):
    import csv

    from reports.tidy import CURVE_COLUMNS, SUMMARY_COLUMNS

    out = tmp_path / "all"
    written = reports.write_report(store, out=out, formats=("html", "svg", "pdf", "csv"), metric="relmse")
    assert written["report"] == out / "index.html" and (out / "summary.md").exists()
    for scene in SCENES:
        for kind in ("relmse", "time-relmse"):  # the report's one metric: its convergence and time plots
            svg, pdf = out / "plots" / f"{scene}_16x16_{kind}.svg", out / "plots" / f"{scene}_16x16_{kind}.pdf"
            assert svg.read_text().lstrip().startswith(("<?xml", "<svg")) and "<path" in svg.read_text()
            assert pdf.read_bytes().startswith(b"%PDF")
    assert (out / "plots" / "seed_cornell_box_400x400_relmse.svg").exists()
    assert (out / "report.pdf").read_bytes().startswith(b"%PDF")  # the whole page as one PDF
    head = list(csv.DictReader((out / "headline.csv").open()))
    assert {(r["scene"], r["strategy"]) for r in head} >= {(sc, st) for sc in SCENES for st in STRATEGIES}
    curves_rows = list(csv.DictReader((out / "curves.csv").open()))
    assert tuple(curves_rows[0]) == CURVE_COLUMNS
    recs = [r for r in load_store(store).records if r["scene"] == SCENES[0] and r["width"] == 16
            and r["strategy"] == "mixture" and r["spp"] == 4]
    (pt,) = [r for r in curves_rows if r["scene"] == SCENES[0] and r["width"] == "16" and r["strategy"] == "mixture"
             and r["spp"] == "4" and r["metric"] == "rmse"]
    vals = sorted(r["rmse"] for r in recs)
    assert float(pt["min"]) == vals[0] and float(pt["max"]) == vals[-1] and int(pt["seeds"]) == len(vals)
    assert float(pt["median"]) == pytest.approx(float(np.median(vals)))
    assert {r["metric"] for r in curves_rows} == {"rmse", "mse_corrected", "relmse", "ssim", "flip"}
    summary_rows = list(csv.DictReader((out / "summary.csv").open()))
    assert tuple(summary_rows[0]) == SUMMARY_COLUMNS
    light = [r for r in summary_rows if r["strategy"] == "light"]
    assert light and all(r["cost_status"] == "biased" and r["efficiency"] == "" and r["time_to_target"] == ""
                         for r in light)
    mis = [r for r in summary_rows if r["strategy"] == "mixture" and r["metric"] == "relmse"]
    assert mis and all(float(r["efficiency"]) > 0 and r["cost_status"] == "" for r in mis)


def test_metric_switches_the_page_and_the_cli(store, tmp_path, capsys):
    from benchmarks.cli import main

    out = tmp_path / "rmse"
    assert main(["report", str(store), "--out", str(out), "--metric", "rmse", "--format", "html,csv",
                 "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "curves.csv" in printed and " fail " not in printed  # --quiet: no table
    html_rmse = (out / "index.html").read_text()
    assert "RMSE slope [95% CI]" in html_rmse
    assert "one error metric throughout: RMSE" in html_rmse
    html_rel = reports.build_report(store, out=tmp_path / "rel")
    assert "relMSE slope [95% CI]" in html_rel.read_text()
    # the equal-time sentence names the metric it compares (it said RMSE for relMSE values)
    assert re.search(r"At equal time \([^)]*\): uniform relMSE ", html_rel.read_text())
    assert re.search(r"At equal time \([^)]*\): uniform RMSE ", html_rmse)
    assert main(["report", str(store), "--format", "html,gif"]) == 2
    assert "unknown format" in capsys.readouterr().err


def test_each_plot_legend_uses_its_own_metrics_slopes(store):
    # regression: under --metric relmse the RMSE plot's legend showed the relMSE slopes
    from reports.sections import _slopes, build_section
    from reports.curves import curves as make_curves

    st = load_store(store)
    sec = build_section(st, "cornell_box", 16, 16, problems=[], metric="relmse")
    recs = st.section_records("cornell_box", 16, 16)
    raw = {(r["renderer"], r["strategy"]): r for r in st.section_rows("cornell_box", 16, 16)}
    rmse = _slopes(sec, make_curves(recs, "rmse"), "rmse")
    rel = _slopes(sec, make_curves(recs, "relmse"), "relmse")
    for key, (slope, note) in rmse.items():
        assert slope == raw[key]["slope"] and note == ""
        assert rel[key][0] == raw[key]["by_metric"]["relmse"]["slope"]


def test_run_facts_name_a_closed_form_reference_as_such():
    from benchmarks.constants import CLOSED_FORM, CLOSED_FORM_SPP
    from reports.tables import facts_table

    meta = {"references": {"furnace": {"variant": CLOSED_FORM, "spp": CLOSED_FORM_SPP, "seed": 0},
                           "cornell_box": {"variant": "llvm_ad_rgb", "spp": 8192, "seed": 1000003}}}
    refs = dict(facts_table(meta))["references"]
    assert refs == "cornell_box: Mitsuba, 8192 spp, seed 1000003; furnace: closed form (exact)"
    assert str(CLOSED_FORM_SPP) not in refs
