"""``rtbench reference SCENE...``: render (or find in the cache) high-spp Mitsuba references."""
from __future__ import annotations

import shutil
import time
from pathlib import Path

from benchmarks.commands import _args as A
from benchmarks.files import slug

HELP = "render a high-spp Mitsuba reference (mean + per-sample variance) into the cache, or report the cached one"


def add_arguments(parser) -> None:
    from benchmarks.references import DEFAULT_REFERENCE_BATCHES, DEFAULT_REFERENCE_SEED

    A.add_scene_args(parser)
    A.add_scene_path_args(parser)
    A.add_spp_args(parser, default=4096)
    A.add_seed_args(parser, default=DEFAULT_REFERENCE_SEED)
    A.add_size_args(parser, width=None)
    parser.add_argument("--batches", type=int, default=DEFAULT_REFERENCE_BATCHES,
                        help="independent batches for the variance image")
    A.add_variant_args(parser)
    A.add_threads_args(parser)
    A.add_cache_arg(parser)
    parser.add_argument("--force", action="store_true", help="render even if a valid cached entry exists")
    parser.add_argument("--export", metavar="DIR", default=None,
                        help="also copy the EXRs to DIR as SCENE_WxH_sppN.exr and SCENE_WxH_sppN_var.exr "
                             "(default: none)")
    A.add_quiet_arg(parser)


def run(args) -> int:
    from mitsuba_scenes import describe_scene, get_scene

    from benchmarks.references import reference
    from benchmarks.scenes import scene_at

    names = A.resolve_scenes(args, suite_names=args.scenes, known=True, required=True)
    variant = A.single_variant(args)
    for scene_name in names:
        own = get_scene(scene_name).camera
        w, h = args.width or own.width, args.height or own.height
        scene = scene_at(scene_name, w, h)
        t0 = time.perf_counter()
        ref = reference(scene, spp=args.spp, seed=args.seed, variant=variant, threads=args.threads,
                        batches=args.batches, cache=args.cache, force=args.force,
                        log=None if args.quiet else print)
        how = "cache hit" if ref.cached else f"rendered in {time.perf_counter() - t0:.1f} s"
        print(f"{scene_name} {w}x{h}: {ref.spp} spp, seed {ref.seed}, Mitsuba {ref.mitsuba_version} "
              f"{ref.variant} ({how})")
        if not args.quiet:
            print(f"  scene:    {describe_scene(scene_name)}, content hash {ref.scene_hash[:16]}")
            print(f"  mean:     {ref.path}")
            print(f"  variance: {ref.variance_path}  (per sample; mean {ref.variance.mean():.4g}, "
                  f"reference noise {ref.noise:.3g})")
        if args.export:
            out = Path(args.export)
            out.mkdir(parents=True, exist_ok=True)
            stem = slug(scene_name, f"{w}x{h}", f"spp{ref.spp}")
            shutil.copyfile(ref.path, out / f"{stem}.exr")
            shutil.copyfile(ref.variance_path, out / f"{stem}_var.exr")
            print(f"  exported to {out / stem}.exr (+ _var.exr)")
    return 0
