"""``rtbench render SCENE``: render one suite scene with our tracer, write EXR and PNG."""
from __future__ import annotations

import argparse
from pathlib import Path

from benchmarks.commands._scene_args import add_scene_path_args, resolve_scenes

HELP = ("render a suite scene (or --scene PATH) with the reference tracer and write "
        "<out>/<scene>_<strategy>.exr and .png")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", help="suite scene name (see `rtbench render --list`)", nargs="?")
    p.add_argument("--list", action="store_true", help="list the suite's scenes and exit")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    p.add_argument("--strategy", default="mis", help="uniform, cosine, light, mixture or mis (default mis)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--width", type=int, default=None, help="image width (default: the scene's)")
    p.add_argument("--height", type=int, default=None, help="image height (default: the width)")
    p.add_argument("--threads", type=int, default=None, help="worker threads (default: all cores)")
    p.add_argument("--exposure", type=float, default=0.0, help="PNG exposure in stops (default 0)")
    p.add_argument("--out", default=".", help="output folder (default: current folder)")
    add_scene_path_args(p)


def run(args) -> int:
    from mitsuba_scenes import describe_scene, get_scene, list_scenes
    from rich.console import Console

    console = Console()
    if args.list or not (args.scene or args.scene_files):
        for name in list_scenes():
            console.print(f"{name:16s} {describe_scene(name)}")
        return 0 if args.list else 2
    rt.imageio.check_exposure(args.exposure)  # before the render, not after it
    params = {}
    if args.width is not None:
        params["width"] = args.width
        params["height"] = args.height if args.height is not None else args.width
    elif args.height is not None:
        raise ValueError("--height needs --width")
    names = resolve_scenes(args, suite_names=[args.scene] if args.scene else [])
    worst = 0
    for name in names:
        worst = max(worst, _render_one(name, get_scene(name, **params), args, console))
    return worst


def _render_one(name, scene, args, console) -> int:
    """Render one scene, write its EXR and PNG, print one line; 1 when samples were NaN/Inf."""
    import reference_tracer as rt
    from mitsuba_scenes import describe_scene
    from rich.progress import BarColumn, Progress, TimeRemainingColumn

    with Progress("[progress.description]{task.description}", BarColumn(), "{task.percentage:>3.0f}%",
                  TimeRemainingColumn(), console=console, transient=True) as bar:
        task = bar.add_task(f"{name} {args.strategy} {args.spp} spp", total=1.0)
        result = rt.render(scene, spp=args.spp, strategy=args.strategy, seed=args.seed, threads=args.threads,
                           progress=lambda done, total: bar.update(task, completed=done / total))
    out = Path(args.out)
    stem = out / f"{name}_{args.strategy}"
    rt.write_exr(stem.with_suffix(".exr"), result.mean)
    rt.write_png(stem.with_suffix(".png"), result.mean, exposure=args.exposure)
    h, w, _ = result.mean.shape
    console.print(f"{name} ({describe_scene(name)}, content hash {scene.content_hash()[:16]})")
    console.print(f"{name}: {w}x{h}, {args.spp} spp, {args.strategy}, seed {args.seed}: "
                  f"{result.seconds:.3f} s on {result.threads} threads, "
                  f"{result.paths_per_second / 1e6:.2f} M paths/s, {result.rays / 1e6:.2f} M rays, "
                  f"{result.nonfinite_samples} NaN/Inf samples, {result.overflow_pixels} overflowed pixels")
    console.print(f"wrote {stem.with_suffix('.exr')} and {stem.with_suffix('.png')}")
    return 1 if result.nonfinite_samples or result.overflow_pixels else 0
