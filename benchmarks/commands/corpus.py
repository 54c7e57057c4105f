"""``rtbench corpus DIR``: every Mitsuba scene of a folder, loaded, imported and judged
(:mod:`benchmarks.corpus`; ``docs/mitsuba.md``); a rerun on the same ``--out`` reuses every verdict
whose scene files, settings and build are unchanged."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from benchmarks.commands import _args as A

HELP = ("coverage of a folder of Mitsuba 3 scenes: which Mitsuba loads, which we import, which agree at a small "
        "film size (or what each still needs); table, corpus.json and corpus.md; exit 1 if one disagrees")

DEFAULT_OUT = "reports/out/corpus"
DEFAULT_SPP = 1024
DEFAULT_WIDTH = 48
DEFAULT_SEED = 1
DEFAULT_TIMEOUT_S = 300.0


def add_arguments(parser) -> None:
    from benchmarks.references import DEFAULT_REFERENCE_BATCHES

    parser.add_argument("dir", metavar="DIR", help="folder of Mitsuba 3 XML scenes (searched recursively)")
    A.add_out_arg(parser, default=f"{DEFAULT_OUT}/PARENT_DIR")
    A.add_spp_args(parser, default=DEFAULT_SPP)
    parser.add_argument("--batches", type=int, default=DEFAULT_REFERENCE_BATCHES,
                        help="independent batches for the variance image")
    parser.add_argument("--width", type=int, default=DEFAULT_WIDTH, metavar="PX",
                        help=f"image width in pixels (default: {DEFAULT_WIDTH}; a film at most this wide keeps "
                             f"its size, a wider one is made this wide and its height keeps the aspect ratio)")
    A.add_seed_args(parser, default=DEFAULT_SEED)
    A.add_threads_args(parser)
    A.add_variant_args(parser)
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S, metavar="S",
                        help="time limit per scene in seconds (load, import and both renders); a scene past it "
                             "is recorded as timeout")
    parser.add_argument("--source", default=None, metavar="TEXT",
                        help="where DIR's files come from (repository, commit, date), written into corpus.json "
                             "and corpus.md (default: DIR's git commit when DIR is in a git checkout)")
    A.add_quiet_arg(parser)


def default_out(folder) -> str:
    """The default output folder: one per scanned folder, named by it and its parent.

    >>> default_out("/data/mitsuba-data/tests/scenes")
    'reports/out/corpus/tests_scenes'
    """
    from benchmarks.files import slug

    p = Path(folder).resolve()
    return f"{DEFAULT_OUT}/{slug(p.parent.name, p.name)}"


def git_provenance(folder) -> dict | None:
    """``{"commit", "date"}`` of the git checkout holding ``folder``, or None (only ``rev-parse``
    and ``show -s`` run, ``core.fsmonitor`` off: nothing runs a repository's hooks)."""
    def git(*cmd):
        try:
            out = subprocess.run(["git", "-c", "core.fsmonitor=false", "-C", str(folder), *cmd],
                                 capture_output=True, text=True, timeout=20)
        except (OSError, subprocess.SubprocessError):
            return None
        return out.stdout.strip() if out.returncode == 0 and out.stdout.strip() else None

    commit = git("rev-parse", "--verify", "HEAD")
    if not commit:
        return None
    return {"commit": commit[:40], "date": (git("show", "-s", "--format=%cI", "HEAD") or "")[:40] or None}


def run(args) -> int:
    from benchmarks.corpus.results import corpus_build, markdown_report, save_results, summary_line, terminal_table
    from benchmarks.corpus.scan import display_path, printable, scan
    from benchmarks.store import store_path, writer_lock
    from benchmarks.text import terminal
    from reference_tracer.imageio import atomic_write

    if not args.timeout > 0:
        raise ValueError(f"--timeout must be > 0, got {args.timeout:g}")
    root = Path(args.dir)
    if not root.is_dir():
        raise ValueError(f"{args.dir}: not a folder")
    root = root.resolve()
    out = store_path(args.out if args.out != f"{DEFAULT_OUT}/PARENT_DIR" else default_out(root))
    variant = A.single_variant(args)
    found = scan(root)
    if not found.scenes:
        raise ValueError(f"{args.dir}: no scene XML file under it ({len(found.fragments)} fragment(s))")
    say = (lambda text: None) if args.quiet else (lambda text: print(terminal(text), file=sys.stderr, flush=True))
    settings = {"spp": args.spp, "batches": args.batches, "seed": args.seed, "width": args.width,
                "variant": variant, "variant_used": None, "threads": A.resolve_threads(args.threads),
                "timeout_s": args.timeout}
    provenance = {"dir": str(root), "dir_name": printable(args.dir), "source": args.source,
                  "git": git_provenance(root), "build": corpus_build(), "settings": settings}
    fragments = {display_path(p, root): [display_path(q, root) for q in by] or [f"root <{found.roots.get(p)}>"]
                 for p, by in found.fragments.items()}
    json_path, md_path = out / "corpus.json", out / "corpus.md"
    say(f"rtbench corpus: {len(found.scenes)} scene(s) and {len(fragments)} fragment(s) under {root}; "
        f"results in {out}")
    with writer_lock(out, say=say):   # a second run on this --out waits, then reuses this one's verdicts
        records, judged = _judge_all(found.scenes, root=root, out=out, settings=settings, provenance=provenance,
                                     fragments=fragments, timeout=args.timeout, say=say)
        save_results(json_path, provenance=provenance, records=records, fragments=fragments)
        atomic_write(md_path, markdown_report(provenance=provenance, records=records, fragments=fragments))
    if not args.quiet:
        print(terminal_table(records))
    print(terminal(f"rtbench corpus: {summary_line(records, fragments)}; {judged} judged now, "
                   f"{len(records) - judged} reused"))
    print(terminal(f"wrote {json_path} and {md_path}"))
    disagree = sum(r["status"] == "disagrees" for r in records.values())
    if disagree:
        print(f"rtbench corpus: {disagree} scene(s) disagree with Mitsuba", file=sys.stderr)
    return 1 if disagree else 0


def _judge_all(scenes, *, root, out, settings, provenance, fragments, timeout, say) -> tuple:
    """Judge every scene not judged already with the same key; ``corpus.json`` is written
    after each one. Returns ``(records, number judged now)``."""
    from benchmarks.corpus.results import load_results, save_results, scene_key
    from benchmarks.corpus.scan import content_hash, display_path
    from benchmarks.corpus.worker import SceneWorker

    json_path = out / "corpus.json"
    old = load_results(json_path, folder=str(root))
    rels = [display_path(p, root) for p in scenes]
    records = {k: v for k, v in old.items() if k in set(rels)}  # kept until judged again: nothing lost
    cache, judged, n = {}, 0, len(rels)
    worker = SceneWorker(log_path=out / "worker.log", variant=settings["variant"], threads=settings["threads"])
    try:
        for i, (path, rel) in enumerate(zip(scenes, rels), 1):
            key = scene_key(content_hash(path, root, cache=cache), settings)
            prev = old.get(rel)
            if prev is not None and prev["key"] == key and (
                    prev["status"] != "timeout" or float(prev.get("timeout_s") or 0) >= timeout):
                records[rel] = prev
                say(f"[{i}/{n}] {rel}: {prev['status']} (earlier run)")
                continue
            job = {k: settings[k] for k in ("spp", "batches", "seed", "width", "threads")}
            rec = worker.judge({"path": str(path), "root": str(root), **job}, timeout=timeout)
            rec.update(path=rel, key=key)
            records[rel] = rec
            judged += 1
            settings["variant_used"] = worker.active_variant or settings["variant_used"]
            save_results(json_path, provenance=provenance, records=records, fragments=fragments)
            say(f"[{i}/{n}] {rel}: {rec['status']} ({rec.get('seconds', 0):.1f} s)")
    finally:
        worker.close()
    if settings["variant_used"] is None:  # every verdict reused: the earlier run's variant
        settings["variant_used"] = next((r.get("variant") for r in records.values() if r.get("variant")), None)
    return records, judged
