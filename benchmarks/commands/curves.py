"""``rtbench curves SCENE... --strategies ... --spps ... --seeds K``: error-vs-spp sweeps into a results store."""
from __future__ import annotations

import argparse

from benchmarks.commands import _args as A
from benchmarks.errors import EXIT_ERROR

HELP = "render error-vs-spp curves (our strategies + Mitsuba path) against cached references into a results store"

DEFAULT_OUT = "reports/out/curves"
DEFAULT_SPPS = (1, 2, 4, 8, 16, 32, 64)
DEFAULT_STRATEGIES = ("uniform", "light", "mixture", "mis")


def default_out(scenes, width, height) -> str:
    """The default results store of a ``curves`` run: one folder per scene set and size, so runs never mix.

    >>> default_out(["cornell_box", "furnace"], 32, 32)
    'reports/out/curves/cornell_box+furnace_32x32'
    """
    return f"{DEFAULT_OUT}/{'+'.join(scenes)}_{width}x{height}"


def add_sweep_options(parser: argparse.ArgumentParser) -> None:
    """Options shared by ``curves`` and ``run``."""
    for add in (A.add_scheduler_arg, A.add_threads_args, A.add_variant_args, A.add_cache_arg, A.add_alpha_args,
                A.add_metric_arg, A.add_quiet_arg):
        add(parser)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    A.add_scene_args(parser)
    A.add_scene_path_args(parser)
    A.add_strategy_args(parser, default=DEFAULT_STRATEGIES)
    A.add_spps_arg(parser, default=DEFAULT_SPPS)
    parser.add_argument("--spp", dest="spps", help=argparse.SUPPRESS)  # deprecated name of --spps
    A.add_seeds_arg(parser, default=3)
    A.add_size_args(parser, width=32)
    A.add_reference_spp_arg(parser, default=None, none_means="max(4096, 32 x the largest spp)")
    parser.add_argument("--no-mitsuba", action="store_true", help="skip Mitsuba's path curve")
    A.add_renderer_arg(parser)  # one more curve per renderer
    A.add_out_arg(parser, default=f"{DEFAULT_OUT}/SCENES_WxH")
    add_sweep_options(parser)


def sweep_kwargs(args, groups) -> dict:
    """``run_sweep``'s keywords from :func:`add_sweep_options`'s options: ``--alpha`` is the run's
    false-alarm rate, each curve of ``groups`` tested at ``alpha / curves`` (Bonferroni)."""
    n = sum(len(g.scenes) * (len(g.strategies) + (1 if g.mitsuba else 0)) for g in groups)
    return dict(threads=args.threads, scheduler=args.scheduler, variant=A.single_variant(args), cache=args.cache,
                alpha=args.alpha / max(n, 1), progress=not args.quiet)


def run(args) -> int:
    from pathlib import Path

    from reports import summary_table
    from benchmarks.commands.parity import check_user_scenes
    from benchmarks.external import register_external
    from benchmarks.sweep import Group, run_sweep

    scenes = A.resolve_scenes(args, suite_names=args.scenes, required=True)
    out = args.out if args.out != f"{DEFAULT_OUT}/SCENES_WxH" else default_out(scenes, args.width, args.height)
    # AOV parity of the scene files first: one that translates differently is not rendered (maps in out/parity)
    if not check_user_scenes(scenes, Path(out) / "parity", command="curves", skipped="nothing was rendered",
                             width=args.width, height=args.height):
        return 1
    ref_spp = args.reference_spp if args.reference_spp is not None else max(4096, 32 * max(args.spps))
    group = Group(scenes=tuple(scenes), strategies=tuple(args.strategies), spps=tuple(args.spps), seeds=args.seeds,
                  width=args.width, height=args.height, mitsuba=not args.no_mitsuba, reference_spp=ref_spp,
                  externals=tuple(register_external(cmd).name for cmd in args.renderer))
    result = run_sweep([group], out=out, **sweep_kwargs(args, [group]))
    if not args.quiet:
        console = A.wide_console(120, soft_wrap=True)
        console.print(summary_table(result.store, metric=args.metric), highlight=False, markup=False)
    print(f"results: {result.store.resolve()}  ({result.done} jobs rendered, {result.skipped} already "
          f"there, {len(result.failed)} failed, {result.seconds:.1f} s)", flush=True)
    A.print_failed_jobs(result.failed)
    return EXIT_ERROR if result.failed else 0  # a job that raised: an internal error
