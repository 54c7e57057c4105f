"""``rtbench run [--preset quick|full]``: references + curves for the suite + the report."""
from __future__ import annotations

import math

from benchmarks.commands import _args as A
from benchmarks.constants import SEED_SCENE, SEED_SIZE, SEED_SPP
from benchmarks.errors import EXIT_ERROR

HELP = "the main job: references and error-vs-spp curves for the whole suite, then the report"

#: planned seconds of the report (plots, image panels, the page and its PDF) in the run's progress.
REPORT_COST = 12.0


def add_arguments(parser) -> None:
    from benchmarks.commands.curves import add_sweep_options
    from benchmarks.sweep.presets import PRESETS

    parser.add_argument("--preset", choices=PRESETS, default=PRESETS[0],
                        help="quick (32x32 images, the whole suite in under three minutes on 2 cores from an "
                             "empty cache) or full (report quality: 256x256, spp to 1024, 4 seeds; hours)")
    A.add_out_arg(parser, default="reports/out/PRESET[_SCENES]")
    parser.add_argument("--scenes", action=A.ListAction, default=None, metavar="SCENE[,SCENE...]",
                        help="only these suite scenes, comma-separated or repeated (default: the whole suite; with "
                             "--scene and no --scenes: only the scene files)")
    parser.add_argument("--no-report", action="store_true", help="skip the report")
    A.add_format_arg(parser)
    add_sweep_options(parser)
    A.add_scene_path_args(parser)


def default_out(preset: str, scenes) -> str:
    """The default results store of a run: one per preset, and one per scene subset.

    >>> default_out("quick", None), default_out("quick", ["furnace", "cornell_box"])
    ('reports/out/quick', 'reports/out/quick_cornell_box+furnace')
    """
    return f"reports/out/{preset}" + (f"_{'+'.join(sorted(scenes))}" if scenes else "")


def run(args) -> int:
    from rich.console import Console

    import reports
    from benchmarks.commands.curves import sweep_kwargs
    from benchmarks.sweep import run_sweep
    from benchmarks.sweep.presets import describe_preset, escalates_tails, preset_groups
    from benchmarks.sweep.progress import Progress, process_seconds

    names = A.resolve_scenes(args, suite_names=list(args.scenes or ())) or None
    out = args.out if args.out != "reports/out/PRESET[_SCENES]" else default_out(args.preset, names)
    groups = preset_groups(args.preset, scenes=names)
    err = Console(stderr=True, soft_wrap=True)
    if not args.quiet:
        err.print(f"rtbench run --preset {args.preset} -> {out}", highlight=False)
        err.print(describe_preset(args.preset, scenes=names), highlight=False)
    kwargs = sweep_kwargs(args, groups)
    bar = Progress(enabled=kwargs.pop("progress"), console=err)
    if not args.no_report:
        bar.plan(REPORT_COST)
    page = None
    try:
        result = run_sweep(groups, out=out, preset=args.preset, progress=bar,
                           escalate_tails=escalates_tails(args.preset), **kwargs)
        if not args.no_report:
            bar.current("report")
            with result.phases("report"):
                page = reports.build_report(result.store, formats=args.format, metric=args.metric)
            bar.advance(REPORT_COST)
    finally:
        bar.stop()
    if not args.quiet:
        _print_headline(result.store, console=A.wide_console(140, soft_wrap=True))
    if page is not None:
        print(f"report: {page.resolve()}", flush=True)
    total = process_seconds()
    startup = max(0.0, total - sum(result.phases.seconds.values()))
    print(f"results: {result.store.resolve()}  ({result.done} jobs rendered, {result.skipped} already there, "
          f"{len(result.failed)} failed)", flush=True)
    print(f"time: start-up {startup:.0f} s, {result.phases.line(total)}", flush=True)
    A.print_failed_jobs(result.failed)
    return EXIT_ERROR if result.failed else 0  # a job that raised: an internal error


def _seed_comparison_line(records) -> str | None:
    """The seed comparison as one sentence, when the store holds it."""
    from reports.curves import seed_comparison
    from reports.tables import fmt

    cmp = seed_comparison(records)
    if cmp is None or not math.isfinite(cmp.get("target_rmse", math.nan)):
        return None
    where = (f"light reaches it at ~{fmt(cmp['light_spp'], 3)} spp ({cmp['method']})"
             if math.isfinite(cmp.get("light_spp", math.nan)) else f"light never does ({cmp['method']})")
    return (f"seed comparison ({SEED_SCENE} {SEED_SIZE}x{SEED_SIZE}): uniform at {SEED_SPP} spp has {cmp['label']} "
            f"{fmt(cmp['target_rmse'], 3)}; {where}")


def _print_headline(store, *, console) -> None:
    """Print the run's answer (the report's first table, :mod:`reports.headline`) and the seed comparison line."""
    from benchmarks.store import read_records
    from benchmarks.text import text_table
    from reports.headline import headline_cells, headline_entries, headline_header
    from reports.store import load_store

    entries = headline_entries(load_store(store))
    if not entries:
        console.print(f"{store}: no summary yet", highlight=False)
        return
    header = [h.replace(": equal spp / equal time", "") for h in headline_header(entries)]
    console.print("noise relative to light sampling, at equal spp / at equal time (x: times as noisy):",
                  highlight=False)
    console.print(text_table(header, headline_cells(entries, intervals=False)), highlight=False, markup=False)
    line = _seed_comparison_line(read_records(store))
    if line:
        console.print(line, highlight=False, markup=False)
