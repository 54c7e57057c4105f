"""``rtbench curves SCENE... --strategies ... --spp ... --seeds K``: error-vs-spp sweeps into a results store."""
from __future__ import annotations

import argparse

from benchmarks.commands._scene_args import add_scene_path_args, resolve_scenes
from benchmarks.constants import BIAS_TEST_ALPHA
from benchmarks.errors import EXIT_ERROR

HELP = "render error-vs-spp curves (our strategies + Mitsuba path) against cached references into a results store"

DEFAULT_OUT = "reports/out/curves"


def _parse_ints(text: str, what: str) -> tuple:
    """CLI text ``"1,2,4"`` -> ``(1, 2, 4)`` (the sweep validates the values themselves)."""
    try:
        values = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise ValueError(f"{what} must be comma-separated integers, got {text!r}") from None
    if not values:
        raise ValueError(f"{what} is empty")
    return values


def _names(text: str) -> tuple:
    return tuple(s.strip() for s in text.split(",") if s.strip())


def add_sweep_options(parser: argparse.ArgumentParser) -> None:
    """Options shared by ``curves`` and ``run``."""
    parser.add_argument("--scheduler", metavar="ADDRESS", default=None,
                        help="Dask distributed scheduler (e.g. tcp://host:8786): one job per worker")
    parser.add_argument("--threads", type=int, default=None,
                        help="threads per local job, ours and Mitsuba alike (default: all cores)")
    parser.add_argument("--variant", default=None, help="Mitsuba variant (default: the fastest that works)")
    parser.add_argument("--cache", default=None, metavar="DIR",
                        help="reference cache (default $RTBENCH_CACHE or ~/.cache/rtbench)")
    parser.add_argument("--alpha", type=float, default=None,
                        help=f"level of the bias test (default {BIAS_TEST_ALPHA})")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenes", nargs="*", metavar="SCENE", help="suite scene name(s)")
    add_scene_path_args(parser)
    parser.add_argument("--strategies", default="uniform,light,mixture,mis",
                        help="our strategies, comma-separated (default uniform,light,mixture,mis)")
    parser.add_argument("--spp", default="1,2,4,8,16,32,64", help="spp ladder, comma-separated")
    parser.add_argument("--seeds", type=int, default=3, help="independent seeds per (curve, spp) (default 3)")
    parser.add_argument("--width", type=int, default=32, help="image width (default 32)")
    parser.add_argument("--height", type=int, default=32, help="image height (default 32)")
    parser.add_argument("--reference-spp", type=int, default=None,
                        help="reference samples per pixel (default max(4096, 32 x the largest spp))")
    parser.add_argument("--no-mitsuba", action="store_true", help="skip Mitsuba's path curve")
    parser.add_argument("--renderer", action="append", default=[], metavar="CMD",
                        help="an external renderer, one more curve (repeatable): a command template with "
                             "{scene_xml} {spp} {seed} {width} {height} {out} that renders the Mitsuba XML to an "
                             "EXR at {out}, e.g. 'mitsuba -m scalar_rgb -D spp={spp} -D seed={seed} -o {out} "
                             "{scene_xml}' (README: External renderers)")
    parser.add_argument("--out", metavar="DIR", default=DEFAULT_OUT, help=f"results store (default {DEFAULT_OUT})")
    add_sweep_options(parser)


def sweep_kwargs(args) -> dict:
    """``run_sweep``'s keyword arguments from the options of :func:`add_sweep_options`."""
    return dict(threads=args.threads, scheduler=args.scheduler, variant=args.variant, cache=args.cache,
                alpha=BIAS_TEST_ALPHA if args.alpha is None else args.alpha, progress=not args.quiet)


def _parity_first(names, out) -> bool:
    """AOV parity of the scene files among ``names``; False when one fails (maps in ``out``/parity)."""
    import sys
    from pathlib import Path

    from benchmarks.commands.parity import check_user_scenes

    if check_user_scenes(names, Path(out) / "parity", say=lambda line: print(line, file=sys.stderr)):
        return True
    print("rtbench curves: the scene file(s) above translate differently in the two renderers; fix that first "
          "(nothing was rendered)", file=sys.stderr)
    return False


def run(args) -> int:
    from rich.console import Console

    from benchmarks.commands._summary import print_summary
    from benchmarks.external import register_external
    from benchmarks.sweep import Group, run_sweep

    spps = _parse_ints(args.spp, "--spp")
    ref_spp = args.reference_spp if args.reference_spp is not None else max(4096, 32 * max(spps))
    scenes = resolve_scenes(args, suite_names=args.scenes)
    if not scenes:
        raise ValueError("no scene: give suite scene names or --scene PATH")
    if not _parity_first(scenes, args.out):
        return 1
    group = Group(scenes=tuple(scenes), strategies=_names(args.strategies), spps=spps, seeds=args.seeds,
                  width=args.width, height=args.height, mitsuba=not args.no_mitsuba, reference_spp=ref_spp,
                  externals=tuple(register_external(cmd).name for cmd in args.renderer))
    result = run_sweep([group], out=args.out, **sweep_kwargs(args))
    console = Console()
    if not console.is_terminal:  # logs and pipes: wide enough for the summary table
        console = Console(width=max(console.width, 120))
    print_summary(result.store, console=console)
    print(f"results: {result.store.resolve()}  ({result.done} jobs rendered, {result.skipped} already "
                  f"there, {len(result.failed)} failed, {result.seconds:.1f} s)", flush=True)
    import sys

    for label, why in result.failed[:10]:
        print(f"  failed: {label}: {why}", file=sys.stderr)
    return EXIT_ERROR if result.failed else 0  # a job that raised: an internal error
