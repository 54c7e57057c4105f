"""``rtbench run [--preset quick|full]``: references + curves for the suite + the report."""
from __future__ import annotations

import argparse
import time

from benchmarks.commands._scene_args import add_scene_path_args, resolve_scenes
from benchmarks.errors import EXIT_ERROR

HELP = "the main job: references and error-vs-spp curves for the whole suite, then the report"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from benchmarks.commands import _args as A
    from benchmarks.commands.curves import add_sweep_options
    from benchmarks.sweep.presets import PRESETS

    parser.add_argument("--preset", choices=PRESETS, default=PRESETS[0],
                        help="quick (small images, whole suite in about 10 minutes on 2 cores) or "
                             "full (report quality: 256x256, spp to 1024, 4 seeds)")
    A.add_out_arg(parser, default="reports/out/PRESET[_SCENES]")
    parser.add_argument("--scenes", default=None, metavar="SCENE[,SCENE...]",
                        help="only these suite scenes, comma-separated (default: the whole suite; with --scene "
                             "and no --scenes: only the scene files)")
    parser.add_argument("--no-report", action="store_true", help="skip the report")
    A.add_format_arg(parser)
    add_sweep_options(parser)
    add_scene_path_args(parser)


def default_out(preset: str, scenes) -> str:
    """The default results store of a run: one per preset, and one per scene subset.

    >>> default_out("quick", None), default_out("quick", ["furnace", "cornell_box"])
    ('reports/out/quick', 'reports/out/quick_cornell_box+furnace')
    """
    return f"reports/out/{preset}" + (f"_{'+'.join(sorted(scenes))}" if scenes else "")


def run(args) -> int:
    from rich.console import Console

    from benchmarks.commands._summary import print_summary
    from benchmarks.commands.curves import sweep_kwargs
    from benchmarks.sweep import run_sweep
    from benchmarks.sweep.presets import describe_preset, preset_groups

    from benchmarks.commands._args import check, name_list

    check(args)
    if args.scenes is not None:
        args.scenes = name_list(args.scenes)
    t0 = time.perf_counter()
    names = resolve_scenes(args, suite_names=args.scenes or [])
    out = args.out if args.out != "reports/out/PRESET[_SCENES]" else default_out(args.preset, names or None)
    groups = preset_groups(args.preset, scenes=names or None)
    console = Console()
    if not console.is_terminal:  # logs and pipes: wide enough for the summary table
        console = Console(width=max(console.width, 120))
    err = Console(stderr=True)
    if not args.quiet:
        err.print(f"rtbench run --preset {args.preset} -> {out}", highlight=False)
        err.print(describe_preset(args.preset, scenes=names or None), highlight=False)
    result = run_sweep(groups, out=out, preset=args.preset, **sweep_kwargs(args, groups))
    page = None
    if not args.no_report:
        try:
            import reports
        except ImportError:
            console.print("report skipped: the reports package is not installed", highlight=False)
        else:
            page = reports.build_report(result.store, formats=args.format, metric=args.metric)
    if not args.quiet:
        print_summary(result.store, console=console, metric=args.metric)
    if page is not None:
        print(f"report: {page.resolve()}", flush=True)
    print(f"results: {result.store.resolve()}  ({result.done} jobs rendered, {result.skipped} already "
          f"there, {len(result.failed)} failed; wall time {time.perf_counter() - t0:.0f} s)", flush=True)
    for label, why in result.failed[:10]:
        print(f"  failed: {label}: {why}")
    return EXIT_ERROR if result.failed else 0  # a job that raised: an internal error
