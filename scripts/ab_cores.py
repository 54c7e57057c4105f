#!/usr/bin/env python3
"""Time two builds of the C++ core against each other, paired call by call (renders or ray queries).

For changes of a few per cent on a shared VM, where separate timed processes disagree by
more than that (PERFORMANCE.md, How to measure): one worker process per build renders on request,
the two alternate render by render (never at the same time), and each round's ratio
compares renders a fraction of a second apart. For example, the installed core against a
build of a change:

    python scripts/ab_cores.py installed /tmp/build/_core.cpython-311-x86_64-linux-gnu.so \\
        --scenes cornell_box glossy_plates --rounds 60

Each render: 128x128 (``--size``), ``--spp`` spp, ``mis``, the wavefront integrator, Russian
roulette from depth 5 (Mitsuba's default), 1 thread. ``--meshes 10000 1000000`` adds renders of
the lit torus of ``benchmarks.speed.rays.mesh_scene`` with those triangle counts (64x64, 8 segments). With ``--rays`` the builds cast rays
instead, as ``rtbench speed --rays`` does (closest hits, distance and primitive), 1 thread,
``--ray-count`` rays a query on the torus of each ``--triangles`` size, random and primary
rays (``--kinds``):

    python scripts/ab_cores.py installed /tmp/build/_core.cpython-311-x86_64-linux-gnu.so \\
        --rays --triangles 1000000 --kinds random --rounds 40

The table gives each build's median seconds a render (or query) and the speed-up of B over A
(time of A / time of B, above 1 where B is faster): the median of the rounds' ratios with its
distribution-free 90% interval (``benchmarks.speed.common.median_order_interval``). Images
are not compared here: ``scripts/compare_builds.py`` does that.
"""
from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    from mitsuba_scenes import SUITE

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", help="baseline core module (.so), or 'installed'")
    parser.add_argument("b", help="core module (.so) compared with it, or 'installed'")
    parser.add_argument("--scenes", nargs="+", default=["cornell_box"], help=f"suite scenes (of {', '.join(SUITE)})")
    parser.add_argument("--rounds", type=int, default=40)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--size", type=int, default=128, help="image width and height")
    parser.add_argument("--meshes", type=int, nargs="+", default=[], metavar="TRIANGLES",
                        help="also render the lit torus of benchmarks.speed.rays.mesh_scene with these triangle "
                             "counts (64x64, --spp, max_depth 8)")
    parser.add_argument("--rays", action="store_true", help="time ray queries instead of renders")
    parser.add_argument("--triangles", type=int, nargs="+", default=[1_000_000], help="--rays: mesh sizes")
    parser.add_argument("--kinds", nargs="+", default=["random", "primary"], choices=["random", "primary"],
                        help="--rays: kinds of rays")
    parser.add_argument("--ray-count", type=int, default=1 << 18, help="--rays: rays a query")
    opts = parser.parse_args(argv)
    for flag in ("rounds", "spp", "size", "ray_count"):
        if getattr(opts, flag) < 1:
            parser.error(f"--{flag.replace('_', '-')} must be at least 1")
    for flag in ("triangles", "meshes"):
        if any(t < 32 for t in getattr(opts, flag)):
            parser.error(f"--{flag} must be at least 32")
    unknown = [s for s in opts.scenes if s not in SUITE]
    if unknown:
        parser.error(f"unknown scene(s) {', '.join(unknown)}; the suite has {', '.join(SUITE)}")
    from reference_tracer.build import core_path

    modules = []
    for name in (opts.a, opts.b):
        path = core_path() if name == "installed" else Path(name)
        if not path.is_file():
            parser.error(f"no core module at {path}")
        modules.append(path.resolve())

    from benchmarks.speed.builds import paired_times
    from benchmarks.speed.common import median_order_interval

    print(f"A: {modules[0]}\nB: {modules[1]}")
    if opts.rays:
        print(f"{opts.rounds} rounds, {opts.ray_count} rays a query, closest hit (distance and primitive), 1 thread")
        cases = {f"{t} {kind}": ("benchmarks.speed.rays.query_torus", {"triangles": t, "kind": kind,
                                                                       "rays": opts.ray_count})
                 for t in opts.triangles for kind in opts.kinds}
        seconds = lambda answer: answer["call_seconds"]  # noqa: E731 - the call, as rtbench speed --rays times it
        print(f"{'mesh, rays':16s} {'A s/query':>11s} {'B s/query':>11s} {'B speed-up':>11s} {'90% interval':>16s}")
    else:
        from mitsuba_scenes import get_scene

        print(f"{opts.rounds} rounds, {opts.size}x{opts.size}, {opts.spp} spp, mis, rr_depth 5, 1 thread")
        cases = {scene: ("benchmarks.speed.render.render_timed",
                         {"scene": get_scene(scene, width=opts.size, height=opts.size, max_depth=50, rr_depth=5),
                          "key": scene, "spp": opts.spp, "strategy": "mis", "seed": 1, "threads": 1})
                 for scene in opts.scenes}
        if opts.meshes:
            from benchmarks.speed.rays import mesh_scene

            cases.update({f"torus {t}": ("benchmarks.speed.render.render_timed",
                                         {"scene": mesh_scene(t, lit=True), "key": f"torus {t}", "spp": opts.spp,
                                          "strategy": "mis", "seed": 1, "threads": 1})
                          for t in opts.meshes})
        seconds = lambda answer: answer[1]  # noqa: E731 - the render's wall time
        print(f"{'scene':16s} {'A s/render':>11s} {'B s/render':>11s} {'B speed-up':>11s} {'90% interval':>16s}")
    for label, request in cases.items():
        rows = paired_times(modules, {label: request}, rounds=opts.rounds, seconds=seconds)[label]
        iv = median_order_interval([a / b for a, b in rows])
        interval = f"[{iv['low']:.3f}, {iv['high']:.3f}]" if iv["low"] is not None else "(5 rounds or more)"
        ta, tb = (statistics.median(r[k] for r in rows) for k in (0, 1))
        print(f"{label:16s} {ta:11.4f} {tb:11.4f} {iv['median']:11.3f} {interval:>16s}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
