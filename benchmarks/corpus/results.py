"""A corpus run's results: ``corpus.json`` (provenance and one record per scene, written after
every scene; a record is reused while its :func:`scene_key` holds), its tables and
``corpus.md``. Text from the corpus is untrusted: the tables escape it.
"""
from __future__ import annotations

import collections
import functools
import hashlib
import json
import math
import re
from importlib import metadata
from pathlib import Path

from reference_tracer.build import build_info

from ..store import read_json, timestamp, write_json
from ..text import markdown, markdown_table, text_table

from .judge import SHARE_LIMIT, STATUSES, Z_LIMIT, compact_feature, cut

__all__ = ["FORMAT", "corpus_build", "scene_key", "load_results", "save_results", "counts", "feature_ranking",
           "needs_text", "table_rows", "terminal_table", "markdown_report", "summary_line"]

#: the ``format`` field of ``corpus.json``.
FORMAT = "rtbench-corpus/1"
#: the most features the "needs" column names before "(+N more)".
NEEDS_SHOWN = 3
#: the most characters of a reason in the terminal table.
TERMINAL_REASON = 90
#: ... and in the Markdown table.
MARKDOWN_REASON = 160


@functools.lru_cache(maxsize=1)
def corpus_build() -> dict:
    """What a verdict depends on besides the scene: our build, the sources of the importer, of
    this package and of the agreement statistic, Mitsuba's version."""
    h = hashlib.sha256()
    info = build_info()
    h.update(info["build"].encode())
    here = Path(__file__).resolve().parent
    root, gate = here.parent.parent, here.parent / "gate"
    for path in [*sorted((root / "mitsuba_scenes").rglob("*.py")), *sorted(here.glob("*.py")),
                 gate / "agreement.py", gate / "filtered.py"]:
        # the path inside the repository: the importer and the translation both have a bsdfs.py
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    try:
        mitsuba = metadata.version("mitsuba")
    except metadata.PackageNotFoundError:
        mitsuba = "unknown"
    h.update(mitsuba.encode())
    return {**info, "mitsuba": mitsuba, "corpus_build": h.hexdigest()[:16]}


def scene_key(content_hash: str, settings: dict) -> str:
    """The key under which a scene's verdict is reused: its content hash, the settings, :func:`corpus_build`."""
    fields = {k: settings.get(k) for k in ("spp", "batches", "seed", "width", "variant")}
    text = json.dumps([content_hash, fields, corpus_build()["corpus_build"]], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def load_results(path, *, folder: str) -> dict:
    """The well-formed records of an earlier run at ``path`` (relative path -> record), or ``{}``;
    ``ValueError`` when it is the run of another folder."""
    data = read_json(path)
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        return {}
    if data.get("dir") != folder:
        raise ValueError(f"{path} holds the results of another folder ({str(data.get('dir'))[:200]!r}); "
                         f"give another --out")
    out = {}
    for rec in data.get("scenes") or []:
        if (isinstance(rec, dict) and isinstance(rec.get("path"), str) and rec.get("status") in STATUSES
                and isinstance(rec.get("key"), str)):
            out[rec["path"]] = rec
    return out


def save_results(path, *, provenance: dict, records: dict, fragments: dict) -> None:
    """Write ``corpus.json`` atomically (provenance, ``updated`` now, counts, records, fragments)."""
    provenance["updated"] = timestamp(utc=True)
    scenes = [records[k] for k in sorted(records)]
    write_json(path, {"format": FORMAT, **provenance, "counts": counts(scenes),
                      "fragment_count": len(fragments), "scenes": scenes,
                      "fragments": [{"path": k, "included_by": v} for k, v in sorted(fragments.items())]})


def counts(records) -> dict:
    """Scenes per status, in :data:`~benchmarks.corpus.judge.STATUSES` order (zeros left out)."""
    c = collections.Counter(r["status"] for r in records)
    return {s: c[s] for s in STATUSES if c[s]}


def feature_ranking(records) -> list:
    """``[(feature, scenes, sole)]`` over the ``refused`` records: each compact feature, the
    scenes that need it and those that need nothing else; most scenes first."""
    blocked, sole = collections.Counter(), collections.Counter()
    for r in records:
        if r["status"] != "refused":
            continue
        feats = list(dict.fromkeys(compact_feature(f) for f in r.get("reasons") or []))
        blocked.update(feats)
        if len(feats) == 1:
            sole[feats[0]] += 1
    return [(f, n, sole[f]) for f, n in sorted(blocked.items(), key=lambda kv: (-kv[1], kv[0]))]


def needs_text(rec, order: dict, *, shown: int = NEEDS_SHOWN) -> str:
    """A refused scene's features by ``order`` (feature -> rank), at most ``shown``, then ``(+N more)``."""
    feats = list(dict.fromkeys(compact_feature(f) for f in rec.get("reasons") or []))
    feats.sort(key=lambda f: (order.get(f, len(order)), f))
    text = "; ".join(feats[:shown])
    return text + (f" (+{len(feats) - shown} more)" if len(feats) > shown else "")


_WHERE = re.compile(r"^(?:At|While loading|Error while loading) .*?\(line \d+, col \d+\):\s*")
_INSTANTIATE = re.compile(r'failed to instantiate (\w+) plugin of type "([^"]*)":\s*(?:\[\w+\]\s*)?')


def short_reason(text: str) -> str:
    """A Mitsuba message for a table: its leading location and plugin boilerplate dropped.

    >>> short_reason('At a.xml (line 5, col 3): failed to instantiate shape plugin of type "Sphere": '
    ...              '[PluginManager] Plugin "Sphere" not found!')
    'shape "Sphere": Plugin "Sphere" not found!'
    """
    head, sep, rest = text.partition(": ") if text.startswith("spectral-only data: ") else ("", "", text)
    return head + sep + _INSTANTIATE.sub(r'\1 "\2": ', _WHERE.sub("", rest))


def _z(g) -> str:
    if isinstance(g, str):
        return g
    return f"{g:+.1f}" if math.isfinite(g) else str(g)


def table_rows(records: dict, *, reason_chars: int) -> list:
    """``[scene, status, needs or reason, global z (R G B), share |z|>4, seconds]`` per record."""
    order = {f: i for i, (f, _, _) in enumerate(feature_ranking(records.values()))}
    rows = []
    for path in sorted(records):
        r = records[path]
        if r["status"] == "refused":
            why = needs_text(r, order)
        else:
            why = "; ".join(short_reason(str(x)) for x in r.get("reasons") or [])
        z = " ".join(_z(g) for g in r["global_z"]) if r.get("global_z") else ""
        share = f"{100 * r['share_z4']:.2f}%" if isinstance(r.get("share_z4"), (int, float)) else ""
        secs = f"{r['seconds']:.1f}" if isinstance(r.get("seconds"), (int, float)) else ""
        rows.append([path, r["status"], cut(why, reason_chars), z, share, secs])
    return rows


HEADER = ["scene", "status", "needs / reason", "global z (R G B)", f"|z|>{Z_LIMIT:g}", "s"]


def terminal_table(records: dict) -> str:
    """The table for a terminal (every cell escaped)."""
    return text_table(HEADER, table_rows(records, reason_chars=TERMINAL_REASON))


def summary_line(records: dict, fragments: dict) -> str:
    """``41 scenes: 2 agrees, 20 refused, ...; 5 fragments``."""
    c = counts(records.values())
    parts = ", ".join(f"{n} {s}" for s, n in c.items())
    return f"{len(records)} scene(s): {parts or 'none'}; {len(fragments)} fragment(s) skipped"


def markdown_report(*, provenance: dict, records: dict, fragments: dict) -> str:
    """``corpus.md``: provenance, counts, the table, the features that block most, the fragments."""
    s = provenance["settings"]
    git = provenance.get("git") or {}
    data = [markdown(provenance["source"])] if provenance.get("source") else []
    if git.get("commit"):
        date = f" ({markdown(git['date'])})" if git.get("date") else ""
        data.append("git commit " + markdown(git["commit"]) + date)
    build = provenance["build"]
    lines = [
        f"Folder {markdown(provenance['dir_name'])}" + (f": {'; '.join(data)}" if data else "") + ".",
        f"Judged {markdown(provenance['updated'][:10])} by `rtbench corpus` with our build "
        f"{markdown(build['build'])}" + (f" ({markdown(build['build_git'])})" if build.get("build_git") else "")
        + f", Mitsuba {markdown(build['mitsuba'])} {markdown(s.get('variant_used') or s.get('variant') or '')}: "
        f"films at most {s['width']} pixels wide (aspect ratio kept), {s['spp']} spp ours (mis) against "
        f"{s['spp']} spp of Mitsuba in {s['batches']} batches; agrees when every channel's global |z| <= "
        f"{Z_LIMIT:g} and at most {SHARE_LIMIT:.0%} of pixel values have |z| > {Z_LIMIT:g}.",
        "",
        "**" + markdown(summary_line(records, fragments)) + "**",
        "",
        markdown_table(HEADER, table_rows(records, reason_chars=MARKDOWN_REASON)),
    ]
    ranking = feature_ranking(records.values())
    if ranking:
        lines += ["", "Features the refused in-scope scenes still need, by the number of scenes each blocks "
                      "(sole: the scenes that need nothing else):", "",
                  markdown_table(["feature", "scenes", "sole"], [[f, n, k] for f, n, k in ranking])]
    if fragments:
        lines += ["", "Fragments (included by other files or not a scene; not judged on their own): "
                  + ", ".join(markdown(k) for k in sorted(fragments)) + "."]
    return "\n".join(lines) + "\n"
