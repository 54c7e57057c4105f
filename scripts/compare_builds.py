#!/usr/bin/env python3
"""Build the C++ core in several configurations on this machine, check that they agree bit
for bit, and time them against each other in alternating processes.

For instruction-set questions (AVX2 against AVX-512, chosen at build time by ``-march``): run it
on the machine in question, e.g. (``rtbench speed --isa avx2`` times such a build against Mitsuba)

    python scripts/compare_builds.py --build avx2="-DRT_NATIVE=OFF -DCMAKE_CXX_FLAGS=-march=x86-64-v3" \\
        --build native="" --threads 16

Each ``--build NAME=ARGS`` is a CMake configuration (ARGS: extra cmake arguments, split
like a shell line); the first is the baseline that the others are compared with. For each
build it prints what the compiler targeted (RT_PACK, AVX-512 or not), then:

- agreement: the images of every suite scene and strategy with both integrators (16x12,
  4 spp), the closest hits of 4096 random rays on a 20k-triangle mesh, and one render with
  1 thread against ``--threads`` threads; every array must equal the baseline's bit for bit
  (fused multiply-adds are off and IEEE semantics kept, so a difference is a bug);
- speed: ``--rounds`` rounds, each build once per round in its own process, in turn:
  closest-hit ray casting on a ``--triangles`` mesh (2^20 random and camera rays, best of
  three queries) and a ``cornell_box`` render (128x128, ``--spp`` spp, ``mis``, wavefront,
  Russian roulette from depth 5 as Mitsuba's default). The table gives medians and each
  build's ratio to the baseline.

Needs cmake, a C++ compiler, numpy and nanobind for the running Python; not Mitsuba.
Exits 1 when builds disagree.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import statistics
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.speed.builds import agreement_arrays, build_core, build_target, run_with_core  # noqa: E402
from reference_tracer.cpus import default_threads  # noqa: E402

_TIMING = """
import dataclasses, json
import numpy as np
import reference_tracer as rt
from mitsuba_scenes import get_scene
from benchmarks.speed.rays import mesh_scene, primary_rays, random_rays
from reference_tracer.probe import core_scene

row = {}
mesh = core_scene(mesh_scene(TRIANGLES))
for kind, make in (("random", random_rays), ("camera", primary_rays)):
    o, d = make(1 << 20)
    o = np.ascontiguousarray(o, dtype=np.float64); d = np.ascontiguousarray(d, dtype=np.float64)
    for threads in sorted({1, THREADS}):
        best = min(mesh.intersect(o, d, threads=threads, preliminary=True)["seconds"] for _ in range(3))
        row[f"{kind} rays, {threads} thr (Mrays/s)"] = len(o) / best / 1e6
scene = dataclasses.replace(get_scene("cornell_box", width=128, height=128), rr_depth=5)
rt.render(scene, spp=4, strategy="mis", seed=1, threads=THREADS)  # warm-up
r = rt.render(scene, spp=SPP, strategy="mis", seed=1, threads=THREADS)
row[f"cornell_box mis rr5, {THREADS} thr (Mpaths/s)"] = 128 * 128 * SPP / r.seconds / 1e6
print("ROW " + json.dumps(row))
"""


def main(argv=None) -> int:
    try:
        return _compare(argv)
    except RuntimeError as e:  # a run against a build failed: its stderr, no traceback
        raise SystemExit(str(e))


def _compare(argv) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", action="append", required=True, metavar="NAME=ARGS",
                        help="a configuration: name, '=', extra cmake arguments (repeat; the first is the baseline)")
    parser.add_argument("--threads", type=int, default=default_threads())
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--triangles", type=int, default=1_000_000)
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--work", type=Path, default=None, help="build folder (default: a temporary one)")
    opts = parser.parse_args(argv)
    builds = []
    for item in opts.build:
        name, sep, args = item.partition("=")
        if not sep or not name.isidentifier():
            parser.error(f"--build {item!r}: expected NAME=ARGS with NAME a plain word")
        builds.append((name, shlex.split(args)))
    if len({n for n, _ in builds}) != len(builds):
        parser.error("--build names must differ")
    for flag in ("threads", "rounds", "triangles", "spp"):
        if getattr(opts, flag) < 1:
            parser.error(f"--{flag} must be at least 1")

    work = opts.work or Path(tempfile.mkdtemp(prefix="rt-builds-"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; "
          f"python {platform.python_version()}; work folder {work}", flush=True)
    jobs = max(1, default_threads() // len(builds))
    with ThreadPoolExecutor(len(builds)) as pool:
        futures = {name: pool.submit(build_core, work / name, *args, jobs=jobs) for name, args in builds}
    modules = {}
    for name, future in futures.items():
        try:
            modules[name] = future.result()
        except (RuntimeError, FileNotFoundError) as e:
            raise SystemExit(f"build {name} failed: {e}")
        print(f"built {name}: {build_target(work / name)}", flush=True)

    import numpy as np

    results = {name: agreement_arrays(module, work / f"{name}.npz", threads=opts.threads)
               for name, module in modules.items()}
    base_name = builds[0][0]
    base = results[base_name]
    disagree = False
    for name, got in results.items():
        differ = [k for k in base.files if not np.array_equal(base[k], got[k], equal_nan=True)]
        threads_differ = not np.array_equal(got["threads/1"], got[f"threads/{opts.threads}"])
        print(f"agreement {name} vs {base_name}: {len(base.files) - len(differ)}/{len(base.files)} arrays identical"
              f"{'; differ: ' + ', '.join(differ[:8]) if differ else ''}; 1 vs {opts.threads} threads "
              f"{'DIFFER' if threads_differ else 'identical'}", flush=True)
        disagree |= bool(differ) or threads_differ

    rows = {name: [] for name in modules}
    for round_ in range(opts.rounds):
        order = list(modules) if round_ % 2 == 0 else list(reversed(modules))
        for name in order:
            out = run_with_core(modules[name], _TIMING, TRIANGLES=opts.triangles, THREADS=opts.threads, SPP=opts.spp)
            row = json.loads(next(line for line in out.splitlines() if line.startswith("ROW "))[4:])
            rows[name].append(row)
            print(f"round {round_ + 1} {name}: " + ", ".join(f"{k} {v:.3f}" for k, v in row.items()), flush=True)
    metrics = list(rows[base_name][0])
    print(f"\nmedian of {opts.rounds} rounds ({opts.triangles:,} triangles; ratio to {base_name})")
    width = max(len(m) for m in metrics)
    print(" " * width + "".join(f"   {n:<18}" for n in modules))
    for metric in metrics:
        base_median = statistics.median(r[metric] for r in rows[base_name])
        cells = []
        for name in modules:
            med = statistics.median(r[metric] for r in rows[name])
            cells.append(f"{med:9.3f}" + (f" ({med / base_median:5.2f}x)" if name != base_name else " " * 9))
        print(f"{metric:<{width}}" + "".join(f" {c:<20}" for c in cells))
    return 1 if disagree else 0


if __name__ == "__main__":
    sys.exit(main())
