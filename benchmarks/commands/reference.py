"""``rtbench reference SCENE...``: render (or find in the cache) high-spp Mitsuba references."""
from __future__ import annotations

import argparse
import shutil
import time
from pathlib import Path

from benchmarks.commands._scene_args import add_scene_path_args, resolve_scenes

HELP = "render a high-spp Mitsuba reference (mean + per-sample variance) into the cache, or report the cached one"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from benchmarks.references import DEFAULT_REFERENCE_BATCHES, DEFAULT_REFERENCE_SEED

    parser.add_argument("scenes", nargs="*", metavar="SCENE", help="suite scene name(s)")
    add_scene_path_args(parser)
    parser.add_argument("--spp", type=int, default=4096, help="samples per pixel (default 4096)")
    parser.add_argument("--seed", type=int, default=DEFAULT_REFERENCE_SEED,
                        help=f"base seed (default {DEFAULT_REFERENCE_SEED}, away from the sweeps' seeds)")
    parser.add_argument("--width", type=int, default=None, help="image width (default: the scene's own)")
    parser.add_argument("--height", type=int, default=None, help="image height (default: the scene's own)")
    parser.add_argument("--batches", type=int, default=DEFAULT_REFERENCE_BATCHES,
                        help=f"independent batches for the variance image (default {DEFAULT_REFERENCE_BATCHES})")
    parser.add_argument("--variant", default=None, help="Mitsuba variant (default: the fastest that works)")
    parser.add_argument("--threads", type=int, default=None, help="rendering threads (default: all cores)")
    parser.add_argument("--cache", default=None, metavar="DIR",
                        help="cache folder (default $RTBENCH_CACHE or ~/.cache/rtbench)")
    parser.add_argument("--force", action="store_true", help="render even if a valid cached entry exists")
    parser.add_argument("--export", metavar="DIR", default=None,
                        help="also copy the EXRs to DIR as SCENE_WxH_sppN.exr and SCENE_WxH_sppN_var.exr")


def run(args) -> int:
    from mitsuba_scenes import describe_scene, get_scene, list_scenes

    from benchmarks.references import reference

    unknown = [s for s in args.scenes if s not in list_scenes()]
    if unknown:
        raise ValueError(f"unknown scene(s) {unknown}; the suite has: {', '.join(list_scenes())}")
    names = resolve_scenes(args, suite_names=args.scenes)
    if not names:
        raise ValueError("no scene: give suite scene names or --scene PATH")
    for name in ("width", "height", "threads"):
        v = getattr(args, name)
        if v is not None and v < 1:
            raise ValueError(f"--{name} must be >= 1, got {v}")
    for scene_name in names:
        scene = get_scene(scene_name)
        w = args.width or scene.camera.width
        h = args.height or scene.camera.height
        scene = scene.with_camera_size(w, h)
        t0 = time.perf_counter()
        ref = reference(scene, spp=args.spp, seed=args.seed, variant=args.variant, threads=args.threads,
                        batches=args.batches, cache=args.cache, force=args.force, log=print)
        took = time.perf_counter() - t0
        how = "cache hit" if ref.cached else f"rendered in {took:.1f} s"
        print(f"{scene_name} {w}x{h}: {ref.spp} spp, seed {ref.seed}, Mitsuba {ref.mitsuba_version} "
              f"{ref.variant} ({how})")
        print(f"  scene:    {describe_scene(scene_name)}, content hash {ref.scene_hash[:16]}")
        print(f"  mean:     {ref.path}")
        print(f"  variance: {ref.variance_path}  (per sample; mean {ref.variance.mean():.4g}, "
              f"reference noise {ref.noise:.3g})")
        if args.export:
            out = Path(args.export)
            out.mkdir(parents=True, exist_ok=True)
            stem = f"{scene_name}_{w}x{h}_spp{ref.spp}"
            shutil.copyfile(ref.path, out / f"{stem}.exr")
            shutil.copyfile(ref.variance_path, out / f"{stem}_var.exr")
            print(f"  exported to {out / stem}.exr (+ _var.exr)")
    return 0
