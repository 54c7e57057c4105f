#!/usr/bin/env python3
"""Time two builds of the C++ core against each other, paired render by render.

For changes of a few per cent on a shared VM, where separate timed processes disagree by
more than that (PERFORMANCE.md round 18): one worker process per build renders on request,
the two alternate render by render (never at the same time), and each round's ratio
compares renders a fraction of a second apart. For example, the installed core against a
build of a change:

    python scripts/ab_cores.py installed /tmp/build/_core.cpython-311-x86_64-linux-gnu.so \\
        --scenes cornell_box glossy_plates --rounds 60

Each render: 128x128 (``--size``), ``--spp`` spp, ``mis``, the wavefront integrator, Russian
roulette from depth 5 (Mitsuba's default), 1 thread. The table gives each build's median
seconds a render and the speed-up of B over A (time of A / time of B, above 1 where B is
faster): the median of the rounds' ratios with a bootstrap 90% interval. Builds of the same
code measured 0.99-1.01 this way (40 rounds). Images are not compared here:
``scripts/compare_builds.py`` and ``benchmarks.speed.builds.agreement_arrays`` do that.
"""
from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _installed_core() -> Path:
    import reference_tracer._core as core

    return Path(core.__file__)


def main(argv=None) -> int:
    from mitsuba_scenes import SUITE

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", help="baseline core module (.so), or 'installed'")
    parser.add_argument("b", help="core module (.so) compared with it, or 'installed'")
    parser.add_argument("--scenes", nargs="+", default=["cornell_box"], help=f"suite scenes (of {', '.join(SUITE)})")
    parser.add_argument("--rounds", type=int, default=40)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--size", type=int, default=128, help="image width and height")
    opts = parser.parse_args(argv)
    for flag in ("rounds", "spp", "size"):
        if getattr(opts, flag) < 1:
            parser.error(f"--{flag} must be at least 1")
    unknown = [s for s in opts.scenes if s not in SUITE]
    if unknown:
        parser.error(f"unknown scene(s) {', '.join(unknown)}; the suite has {', '.join(SUITE)}")
    modules = []
    for name in (opts.a, opts.b):
        path = _installed_core() if name == "installed" else Path(name)
        if not path.is_file():
            parser.error(f"no core module at {path}")
        modules.append(path.resolve())

    from benchmarks.speed.builds import median_interval, paired_render_times

    print(f"A: {modules[0]}\nB: {modules[1]}")
    print(f"{opts.rounds} rounds, {opts.size}x{opts.size}, {opts.spp} spp, mis, rr_depth 5, 1 thread")
    print(f"{'scene':16s} {'A s/render':>11s} {'B s/render':>11s} {'B speed-up':>11s} {'90% interval':>16s}")
    for scene in opts.scenes:
        rows = paired_render_times(modules, [scene], rounds=opts.rounds, spp=opts.spp, size=opts.size)[scene]
        med, low, high = median_interval([a / b for a, b in rows])
        ta = statistics.median(r[0] for r in rows)
        tb = statistics.median(r[1] for r in rows)
        print(f"{scene:16s} {ta:11.4f} {tb:11.4f} {med:11.3f} {f'[{low:.3f}, {high:.3f}]':>16s}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
