"""``rtbench compare STORE_A STORE_B``: did B (a new build, a new renderer) get faster, slower, or wrong?"""
from __future__ import annotations

import sys
from pathlib import Path

from benchmarks.commands import _args as A

HELP = ("compare two results stores curve by curve: both curves on one plot, slope and efficiency of B over A "
        "with bootstrap 95 percent intervals, the gate's verdict of B against A; exit 1 if a verdict fails")


def add_arguments(parser) -> None:
    from benchmarks.tails import DEFAULT_TAIL_SPP

    parser.add_argument("store_a", metavar="STORE_A", help="the baseline results store")
    parser.add_argument("store_b", metavar="STORE_B", help="the results store to judge")
    A.add_alpha_args(parser)
    A.add_tail_spp_arg(parser, default=DEFAULT_TAIL_SPP)  # of ours when B is this build
    A.add_threads_args(parser)
    A.add_cache_arg(parser)
    A.add_renderer_arg(parser)  # external renderers whose B curves may be re-run for their variance
    A.add_scene_path_args(parser)  # scene files B rendered: the store's own file is never loaded
    A.add_out_arg(parser, default="rtbench-compare")  # the page: index.html, compare.md, plots
    A.add_json_arg(parser)  # one row per curve
    A.add_quiet_arg(parser)


def run(args) -> int:
    from benchmarks.compare import compare_stores, estimator_knowledge
    from benchmarks.external import register_external
    from benchmarks.store import write_json
    from benchmarks.text import terminal, text_table
    from reports.compare import figures, write_compare_page

    for p in (args.store_a, args.store_b):
        if not (Path(p) / "results.jsonl").is_file():
            raise ValueError(f"{p} is not a results store (no results.jsonl)")
    out = Path(args.out).expanduser()
    if out.exists() and not out.is_dir():  # before any rendering, as report checks it
        raise ValueError(f"compare output {str(out)!r} exists and is not a folder")
    if args.tail_spp == 1:
        raise ValueError(f"--tail-spp must be 0 (none) or >= 2, got {args.tail_spp}")
    A.warn_tail_spp("compare", args.tail_spp)
    A.resolve_scenes(args)  # only files named here run; a store's scene_source never does
    knowledge = estimator_knowledge(tail_spp=args.tail_spp, threads=A.resolve_threads(args.threads),
                                    cache=args.cache, externals=[register_external(cmd) for cmd in args.renderer],
                                    log=A.stderr_log(args))
    rows = compare_stores(args.store_a, args.store_b, alpha=args.alpha, estimator=knowledge)
    if not args.quiet:  # the page's table of each curve
        for c in rows:
            print(terminal(f"{c.label}\n") + text_table(["figure", "value"], figures(c)) + "\n")
    page = write_compare_page(rows, args.out, name_a=str(args.store_a), name_b=str(args.store_b))
    print(f"page: {page.resolve()}")
    if args.json:
        write_json(args.json, [c.to_dict() for c in rows])
    failed = [c for c in rows if c.verdict == "fail"]
    for c in failed:
        print(terminal(f"rtbench compare: B differs from A in {c.label}: p = {c.p_value:.3g}, relative bias "
                       f"{c.relative_bias:+.2%}"), file=sys.stderr)
    return 1 if failed else 0
