"""``rtbench render SCENE``: render a scene with our tracer (and, with ``--mitsuba``, Mitsuba) to EXR and PNG."""
from __future__ import annotations

import argparse
from pathlib import Path

from benchmarks.commands import _args as A
from benchmarks.files import slug

HELP = ("render a suite scene (or --scene PATH) with our tracer (one image per --strategies) and, with --mitsuba, "
        "with Mitsuba too; writes <out>/<scene>_<W>x<H>_<renderer>_spp<N>_seed<S>.exr and .png")

DEFAULT_OUT = "rtbench-out/render"


def add_arguments(p) -> None:
    A.add_scene_args(p, nargs="?", what="suite scene name")
    A.add_list_arg(p)
    A.add_spp_args(p, default=64)
    A.add_strategy_args(p, default=("mis",))
    p.add_argument("--strategy", action=A.ListAction,
                   dest="strategies", help=argparse.SUPPRESS)  # the older singular name
    A.add_seed_args(p)
    A.add_size_args(p, width=None)
    p.add_argument("--mitsuba", action="store_true",
                   help="also render the scene with Mitsuba's path integrator (in --variant)")
    A.add_variant_args(p)
    A.add_threads_args(p)
    p.add_argument("--exposure", type=float, default=0.0, help="PNG exposure in stops")
    A.add_out_arg(p, default=DEFAULT_OUT)
    A.add_quiet_arg(p)
    A.add_scene_path_args(p)


def file_stem(scene: str, width: int, height: int, renderer: str, spp: int, seed: int) -> str:
    """The name of a render's files: every setting that changes the image, so renders never overwrite each other.

    >>> file_stem("cornell_box", 32, 32, "mis", 64, 0)
    'cornell_box_32x32_mis_spp64_seed0'
    """
    return slug(scene, f"{width}x{height}", renderer, f"spp{spp}", f"seed{seed}")


def run(args) -> int:
    import reference_tracer as rt
    from mitsuba_scenes import describe_scene, get_scene, list_scenes
    from rich.console import Console

    console = Console()
    if args.list or not (args.scenes or args.scene_files):
        for name in list_scenes():  # on stdout: the answer of --list, the choices of a command without a scene
            console.print(f"{name:16s} {describe_scene(name)}", markup=False)
        if args.list:
            return 0
        raise ValueError("no scene: give a suite scene name (`rtbench render --list` lists them) or --scene PATH")
    unknown = [s for s in args.strategies if s not in rt.STRATEGIES]
    if unknown:
        raise ValueError(f"unknown strateg{'y' if len(unknown) == 1 else 'ies'} {', '.join(unknown)}; "
                         f"choose from {', '.join(rt.STRATEGIES)}")
    rt.imageio.check_exposure(args.exposure)  # before the render, not after it
    variant = A.single_variant(args)
    if args.mitsuba:  # a variant that does not exist or work here: refused before anything is rendered
        from mitsuba_scenes.variants import select_variant

        variant = select_variant(variant)
    params = {} if args.width is None else {"width": args.width, "height": args.height}
    names = A.resolve_scenes(args, suite_names=[args.scenes] if args.scenes else [])
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    return max(_render_scene(name, get_scene(name, **params), args, variant, out, console) for name in names)


def _render_scene(name, scene, args, variant, out: Path, console) -> int:
    """Render one scene with every strategy (and, with ``--mitsuba``, Mitsuba in ``variant``, the one
    :func:`~mitsuba_scenes.variants.select_variant` chose), write EXR and PNG, print one line each;
    1 when samples were NaN/Inf or pixels overflowed."""
    import reference_tracer as rt
    from mitsuba_scenes import describe_scene
    from rich.progress import BarColumn, Progress, TimeRemainingColumn

    w, h = scene.camera.width, scene.camera.height
    if not args.quiet:
        console.print(f"{name} ({describe_scene(name)}, content hash {scene.content_hash()[:16]})", highlight=False,
                      markup=False)
    bad = 0
    for strategy in dict.fromkeys(args.strategies):
        with Progress("[progress.description]{task.description}", BarColumn(), "{task.percentage:>3.0f}%",
                      TimeRemainingColumn(), console=console, transient=True, disable=args.quiet) as bar:
            task = bar.add_task(f"{name} {strategy} {args.spp} spp", total=1.0)
            result = rt.render(scene, spp=args.spp, strategy=strategy, seed=args.seed, threads=args.threads,
                               progress=lambda done, total: bar.update(task, completed=done / total))
        if not args.quiet:
            console.print(f"{name}: {w}x{h}, {args.spp} spp, {strategy}, seed {args.seed}: "
                          f"{result.seconds:.3f} s on {result.threads} threads, "
                          f"{result.paths_per_second / 1e6:.2f} M paths/s, {result.rays / 1e6:.2f} M rays, "
                          f"{result.nonfinite_samples} NaN/Inf samples, {result.overflow_pixels} overflowed pixels",
                          highlight=False)
        _write(out / file_stem(name, w, h, strategy, args.spp, args.seed), result.mean, args.exposure)
        bad += bool(result.nonfinite_samples or result.overflow_pixels)
    if args.mitsuba:
        from mitsuba_scenes import render_mitsuba

        res = render_mitsuba(scene, spp=args.spp, seed=args.seed, variant=variant, threads=args.threads, batches=1)
        if not args.quiet:
            console.print(f"{name}: Mitsuba {variant} path, {args.spp} spp, seed {args.seed}: "
                          f"{res.seconds:.3f} s", highlight=False)
        _write(out / file_stem(name, w, h, f"mitsuba-{variant}", args.spp, args.seed), res.mean, args.exposure)
    return 1 if bad else 0


def _write(stem: Path, mean, exposure: float) -> None:
    import reference_tracer as rt

    rt.write_exr(stem.with_suffix(".exr"), mean)
    rt.write_png(stem.with_suffix(".png"), mean, exposure=exposure)
    print(f"wrote {stem}.exr and {stem}.png")
