#!/usr/bin/env python3
"""Build the C++ core in several configurations on this machine, check that they agree bit
for bit, and time them against each other in alternating processes.

For the instruction-set question of issue 17 (AVX2 against AVX-512, chosen at build time by
``-march``): run it on the machine in question, e.g.

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
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# Runs in a child process whose reference_tracer._core is the build under test.
_PREAMBLE = """
import importlib.util, sys
sys.path.insert(0, {root!r})
spec = importlib.util.spec_from_file_location("reference_tracer._core", {module!r})
core = importlib.util.module_from_spec(spec); spec.loader.exec_module(core)
sys.modules["reference_tracer._core"] = core
"""

_AGREEMENT = """
import dataclasses
import numpy as np
import reference_tracer as rt
from mitsuba_scenes import SUITE, get_scene
from benchmarks.speed.rays import mesh_scene, random_rays
from reference_tracer.render import core_scene

out = {}
for name in SUITE:
    for strategy in rt.STRATEGIES:
        scene = get_scene(name, width=16, height=12)
        for integrator in ("scalar", "wavefront"):
            r = rt.render(scene, spp=4, strategy=strategy, seed=5, threads=2, integrator=integrator)
            out[f"{name}/{strategy}/{integrator}"] = r.mean
scene = get_scene("cornell_box", width=64, height=48)
for threads in (1, THREADS):
    out[f"threads/{threads}"] = rt.render(scene, spp=16, strategy="mis", seed=9, threads=threads).mean
mesh = core_scene(mesh_scene(20_000))
o, d = random_rays(4096, seed=3)
hits = mesh.intersect(np.ascontiguousarray(o, dtype=np.float64), np.ascontiguousarray(d, dtype=np.float64), threads=2)
out["rays/t"], out["rays/prim"] = np.asarray(hits["t"]), np.asarray(hits["prim"])
np.savez(PATH, **out)
"""

_TIMING = """
import dataclasses, json
import numpy as np
import reference_tracer as rt
from mitsuba_scenes import get_scene
from benchmarks.speed.rays import mesh_scene, primary_rays, random_rays
from reference_tracer.render import core_scene

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


def _run(module: Path, body: str, **values) -> str:
    script = _PREAMBLE.format(root=str(ROOT), module=str(module)) + body
    for key, value in values.items():
        script = script.replace(key, repr(value))
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT,
                          env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1"))
    if done.returncode != 0:
        raise SystemExit(f"a run with {module} failed:\n{done.stderr[-3000:]}")
    return done.stdout


def _build(name: str, args: list[str], work: Path, jobs: int) -> subprocess.Popen:
    build_dir = work / name
    configure = ["cmake", "-S", str(ROOT), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
                 f"-DPython_EXECUTABLE={sys.executable}", *args]
    line = f"{shlex.join(configure)} && cmake --build {shlex.quote(str(build_dir))} --target _core -j {jobs}"
    log = open(work / f"{name}.log", "w")
    return subprocess.Popen(["bash", "-c", line], stdout=log, stderr=subprocess.STDOUT)


def _targets(build_dir: Path) -> str:
    """What the compiler targeted: the macros simd.h reads, from the build's own compiler and
    flags (CMake's flags.make), and the pack width they give (simd.h's RT_PACK rule)."""
    flags_file = (build_dir / "CMakeFiles" / "_core.dir" / "flags.make").read_text()
    fields = dict(line.split(" = ", 1) for line in flags_file.splitlines() if " = " in line)
    compiler = next((line.split("=", 1)[1] for line in (build_dir / "CMakeCache.txt").read_text().splitlines()
                     if line.startswith("CMAKE_CXX_COMPILER:")), "c++")
    flags = shlex.split(fields.get("CXX_FLAGS", "")) + shlex.split(fields.get("CXX_DEFINES", ""))
    probe = subprocess.run([compiler, *flags, "-dM", "-E", "-x", "c++", "/dev/null"], capture_output=True, text=True)
    macros = dict((parts[1], parts[2] if len(parts) > 2 else "") for parts in
                  (line.split(" ", 2) for line in probe.stdout.splitlines()) if len(parts) > 1)
    isa = [m for m in ("__AVX2__", "__FMA__", "__AVX512F__") if m in macros]
    pack = macros.get("RT_PACK_WIDTH") or ("8" if "__AVX512F__" in macros else "4")
    march = [f for f in flags if f.startswith("-march=")] or ["(compiler default)"]
    return f"{Path(compiler).name} {' '.join(march)}: {' '.join(isa) or 'no AVX2/AVX-512'}, packs of {pack}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", action="append", required=True, metavar="NAME=ARGS",
                        help="a configuration: name, '=', extra cmake arguments (repeat; the first is the baseline)")
    parser.add_argument("--threads", type=int, default=os.cpu_count() or 1)
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
    jobs = max(1, (os.cpu_count() or 2) // len(builds))
    procs = [(name, _build(name, args, work, jobs)) for name, args in builds]
    modules = {}
    for name, proc in procs:
        if proc.wait() != 0:
            print((work / f"{name}.log").read_text()[-4000:])
            raise SystemExit(f"build {name} failed")
        modules[name] = next((work / name).glob("_core*.so"))
        print(f"built {name}: {_targets(work / name)}", flush=True)

    import numpy as np

    results = {}
    for name, module in modules.items():
        path = work / f"{name}.npz"
        _run(module, _AGREEMENT, PATH=str(path), THREADS=opts.threads)
        results[name] = np.load(path)
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
            out = _run(modules[name], _TIMING, TRIANGLES=opts.triangles, THREADS=opts.threads, SPP=opts.spp)
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
