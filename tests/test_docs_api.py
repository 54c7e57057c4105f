"""The docs name the API as it is: every dotted name they quote resolves the way a reader would use it,
every ``from ... import ...`` they quote runs, the Mitsuba page names ``mitsuba_scenes``' exports, and the
README says what ``rtbench report`` writes by default."""
from __future__ import annotations

import importlib
import re

import pytest

from repo_paths import ROOT

DOCS = sorted([ROOT / "README.md", ROOT / "ARCHITECTURE.md", *(ROOT / "docs").glob("*.md"),
               *(ROOT / "benchmarks").glob("*.md")])
PACKAGES = ("reference_tracer", "mitsuba_scenes", "benchmarks", "reports")
DOTTED = re.compile(rf"`((?:{'|'.join(PACKAGES)})(?:\.[A-Za-z_]\w*)+)(?:\(\))?`")
FROM_IMPORT = re.compile(rf"`(from (?:{'|'.join(PACKAGES)})[\w.]* import \w+(?:, \w+)*)`")


def _quoted(pattern):
    return sorted({(doc.relative_to(ROOT).as_posix(), m.group(1))
                   for doc in DOCS for m in pattern.finditer(doc.read_text())})


def _resolve(name: str):
    """``name`` as a reader's ``import root`` then attribute access gets it (its modules imported first)."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):  # load the submodules the name runs through
        try:
            importlib.import_module(".".join(parts[:i]))
            break
        except ImportError:
            continue
    obj = importlib.import_module(parts[0])
    for part in parts[1:]:
        obj = getattr(obj, part)  # AttributeError: the docs name something that is not there
    return obj


@pytest.mark.parametrize("doc, name", _quoted(DOTTED))
def test_every_dotted_name_in_the_docs_resolves(doc, name):
    """``reference_tracer.render.BLIND_TO_DELTA_LIGHTS`` did not: ``reference_tracer.render`` is the function."""
    _resolve(name)


@pytest.mark.parametrize("doc, statement", _quoted(FROM_IMPORT))
def test_every_import_in_the_docs_runs(doc, statement):
    exec(statement, {})


def test_the_mitsuba_page_names_the_exported_translation_functions():
    """It named ``to_dict``; the function is ``to_mitsuba``."""
    import mitsuba_scenes

    first = (ROOT / "docs" / "mitsuba.md").read_text().split("\n\n")[1]
    named = re.findall(r"`(\w+)`", first)
    assert {"to_mitsuba", "to_xml", "from_mitsuba"} <= set(named), first
    assert [n for n in named if n not in mitsuba_scenes.__all__ and n != "mitsuba_scenes"] == [], first


def test_the_readme_says_what_rtbench_report_writes_by_default():
    """It said `index.html, summary.md, plots and CSVs`; by default (``--format html``) only the page
    and the summary are written, ``--format html,svg,pdf,csv`` adds the rest."""
    from benchmarks.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert sub.choices["report"].get_default("format") == "html"
    lines = [ln for ln in (ROOT / "README.md").read_text().splitlines() if ln.startswith("rtbench report ")]
    default = [ln for ln in lines if "--format" not in ln.split("#")[0]]
    assert len(default) == 1, lines
    comment = default[0].split("#", 1)[1]
    assert "index.html" in comment and "summary.md" in comment
    assert not re.search(r"csv|svg|pdf|plots/", comment, re.IGNORECASE), comment
    every = [ln for ln in lines if "--format html,svg,pdf,csv" in ln]
    assert every and all(w in every[0].split("#", 1)[1].lower() for w in ("svg", "pdf", "csv")), lines
