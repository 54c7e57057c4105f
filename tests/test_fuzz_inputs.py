"""Fuzzing the readers of untrusted input: the results-store loader and the Mitsuba XML importer.

Each generated input must end in the reader's documented outcome: a result, or a
``ValueError`` (exit 2) with a message; never another exception (a traceback), a hang or a
path outside the store. Inputs come from hypothesis with a fixed seed (``derandomize``), so
a failure reproduces. ``RTBENCH_FUZZ_EXAMPLES`` sets the number of inputs of each test
(default 150 in the test suite; ``RTBENCH_FUZZ_EXAMPLES=2000 pytest tests/test_fuzz_inputs.py``
is the long run).
"""
from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmarks.store import RESULTS, SUMMARY

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "xml"
EXAMPLES = int(os.environ.get("RTBENCH_FUZZ_EXAMPLES", "150"))
FUZZ = settings(max_examples=EXAMPLES, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large])

# ------------------------------------------------------------------------------------ stores

NASTY_TEXT = st.sampled_from(["", ".", "..", "../../x", "/etc/passwd", "/dev/zero", "a/b", "\x1b[2J", "<b>", "=1+1",
                              "|", "x" * 300, "cornell_box", "ours", "mis", "mitsuba", "path", "images/a.exr",
                              "références", "\x00", "nan"])
NUMBERS = st.one_of(st.integers(-2**70, 2**70), st.floats(allow_nan=True, allow_infinity=True),
                    st.sampled_from([0, 1, 4, 16, -1, 2**63]))
SCALARS = st.one_of(st.none(), st.booleans(), NUMBERS, NASTY_TEXT, st.text(max_size=20))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                       st.dictionaries(st.text(max_size=8), inner, max_size=3)),
                      max_leaves=8)
FIELDS = ("scene", "renderer", "strategy", "spp", "seed", "width", "height", "build", "image", "stats_image",
          "stats_variance_image", "mse", "rmse", "relmse", "ssim", "flip", "mse_corrected", "seconds", "variance")
RECORD = st.fixed_dictionaries({}, optional={k: st.one_of(VALUES, NASTY_TEXT, NUMBERS) for k in FIELDS})
LINE = st.one_of(RECORD.map(json.dumps), VALUES.map(lambda v: json.dumps(v, allow_nan=True)),
                 st.binary(max_size=40).map(lambda b: b.decode("latin-1")), st.just("{" * 2000))
META = st.one_of(st.none(), VALUES, st.fixed_dictionaries(
    {}, optional={"references": st.dictionaries(NASTY_TEXT, st.one_of(VALUES, st.fixed_dictionaries(
        {"path": NASTY_TEXT}, optional={"spp": NUMBERS, "sha256": NASTY_TEXT}))), "preset": VALUES,
        "versions": VALUES, "machine": VALUES, "total_seconds": NUMBERS}))
SUMMARY_ROWS = st.lists(st.fixed_dictionaries({}, optional={k: st.one_of(VALUES, NASTY_TEXT, NUMBERS)
                                                             for k in FIELDS + ("slope", "bias_significant",
                                                                                "cost_status", "efficiency")}),
                        max_size=4)


def _write_store(root: Path, lines, meta, rows) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    for p in root.iterdir():
        p.unlink()
    (root / RESULTS).write_text("\n".join(lines) + "\n", encoding="utf-8", errors="surrogatepass")
    if meta is not None:
        (root / "meta.json").write_text(json.dumps(meta, allow_nan=True))
    if rows is not None:
        (root / SUMMARY).write_text(json.dumps({"rows": rows}, allow_nan=True))
    return root


@FUZZ
@given(lines=st.lists(LINE, max_size=6), meta=META, rows=st.one_of(st.none(), SUMMARY_ROWS))
def test_store_loader_and_text_outputs(tmp_path, lines, meta, rows):
    from reports.build import _markdown, _collect, summary_table
    from reports.store import load_store
    from reports.tidy import curves_csv, summary_csv

    store = _write_store(tmp_path / "store", lines, meta, rows)
    try:
        st_ = load_store(store)
    except ValueError:
        return
    for rec in st_.records:
        rel = rec.get("image")
        if rel is None:
            continue
        try:
            st_.read_image(rel)
        except ValueError:
            pass
    try:
        sections, cmp, _, problems = _collect(st_, "relmse")
        _markdown(st_, sections, cmp, problems)
        summary_table(st_)
        curves_csv(st_)
        summary_csv(st_)
    except ValueError:
        pass


# ------------------------------------------------------------------------------------ XML

VALUES_XML = ["nan", "inf", "-inf", "-1", "0", "1e999", "", "$nope", "1, 2", "a, b, c", "../../etc/passwd",
              "/dev/zero", "9" * 400, "true", "x" * 50, "0, 0, 0", "1e-320"]
TAGS = ["shape", "bsdf", "emitter", "texture", "rfilter", "sampler", "film", "integrator", "medium", "ref",
        "transform", "rgb", "spectrum", "float", "integer", "string", "boolean", "point", "vector", "include",
        "default", "path"]
TYPES = ["sphere", "rectangle", "cube", "obj", "ply", "serialized", "diffuse", "conductor", "roughconductor",
         "dielectric", "plastic", "area", "point", "envmap", "gaussian", "box", "path", "direct", "volpath",
         "twosided", "checkerboard", "nope"]


def _fixtures():
    return {p.name: p.read_text() for p in sorted(FIXTURES.glob("*.xml"))}


_ATTR = re.compile(r'(value|type|name|id|angle|x|y|z|origin|target|up)="([^"]*)"')


@st.composite
def mutated_xml(draw):
    texts = _fixtures()
    text = texts[draw(st.sampled_from(sorted(texts)))]
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["value", "delete", "insert", "truncate", "duplicate"]))
        if not text.strip():
            break
        if kind == "value":
            spots = list(_ATTR.finditer(text))
            if spots:
                m = spots[draw(st.integers(0, len(spots) - 1))]
                new = draw(st.sampled_from(VALUES_XML + TYPES))
                text = text[:m.start(2)] + new + text[m.end(2):]
        elif kind == "delete":
            lines = text.splitlines()
            i = draw(st.integers(0, len(lines) - 1))
            text = "\n".join(lines[:i] + lines[i + 1:])
        elif kind == "insert":
            lines = text.splitlines()
            i = draw(st.integers(1, max(1, len(lines) - 1)))
            tag, typ = draw(st.sampled_from(TAGS)), draw(st.sampled_from(TYPES))
            val = draw(st.sampled_from(VALUES_XML))
            lines.insert(i, f'<{tag} type="{typ}" name="{draw(st.sampled_from(["x", "radiance", "filename"]))}" '
                            f'value="{val}"/>')
            text = "\n".join(lines)
        elif kind == "truncate":
            text = text[:draw(st.integers(0, len(text)))]
        else:
            lines = text.splitlines()
            i = draw(st.integers(0, len(lines) - 1))
            text = "\n".join(lines[:i + 1] + lines[i:])
    return text


@pytest.fixture(scope="module")
def mitsuba_ready():
    from mitsuba_scenes.variants import import_mitsuba

    return import_mitsuba()


@FUZZ
@given(text=mutated_xml())
def test_importer_refuses_with_a_value_error_only(tmp_path, mitsuba_ready, text):
    from mitsuba_scenes import from_mitsuba

    path = tmp_path / "fuzz.xml"
    path.write_text(text)
    try:
        scene = from_mitsuba(path)
    except ValueError:
        return
    assert scene.camera.width > 0 and scene.shapes is not None
