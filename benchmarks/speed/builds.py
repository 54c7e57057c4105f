"""Other builds of the C++ core, side by side with the installed one.

The core's configurations (``-march``, the pack width ``RT_PACK_WIDTH``, the compiler) must
give the same images bit for bit on one machine: fused multiply-adds are off
(``-ffp-contract=off``), the explicit ones are correctly rounded, IEEE semantics are kept.
These functions build a configuration with CMake into a folder of its own, run code against
that build in a fresh interpreter (:func:`reference_tracer.build.use_core`, so that the
calling process keeps its module), and collect the arrays that must agree. Used by
``scripts/compare_builds.py`` and by the tests that rebuild the core
(``tests/reference_tracer/test_builds.py``, ``tests/reference_tracer/test_wavefront.py``).

Examples
--------
>>> from benchmarks.speed.builds import AGREEMENT_SCRIPT
>>> "integrator" in AGREEMENT_SCRIPT
True
"""
from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["ROOT", "AGREEMENT_SCRIPT", "build_core", "run_with_core", "agreement_arrays", "build_target",
           "paired_render_times", "paired_ray_times", "median_interval"]

#: The repository's root (the CMake project).
ROOT = Path(__file__).resolve().parents[2]

# Makes `module` the fresh interpreter's core before anything loads it.
_PREAMBLE = """
import sys
sys.path.insert(0, {root!r})
from reference_tracer.build import use_core
use_core({module!r})
"""

#: What every build must give bit for bit (PATH: the .npz written, THREADS: the thread
#: count compared with one thread): each suite scene x strategy x integrator at 16x12,
#: 4 spp; a 64x48 ``cornell_box`` rendered with 1 and THREADS threads; the closest hits of
#: 4096 random rays on a 20k-triangle mesh.
AGREEMENT_SCRIPT = """
import numpy as np
import reference_tracer as rt
from mitsuba_scenes import SUITE, get_scene
from benchmarks.speed.rays import mesh_scene, random_rays
from reference_tracer.probe import core_scene

out = {}
for name in SUITE:
    for strategy in rt.STRATEGIES:
        scene = get_scene(name, width=16, height=12)
        for integrator in rt.INTEGRATORS:
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


def build_core(build_dir: Path, *cmake_args: str, cxx: str | None = None, jobs: int = 2) -> Path:
    """Configure and build the ``_core`` target into ``build_dir``; return the module's path.

    ``cmake_args`` are extra CMake arguments (``-DRT_NATIVE=OFF``, ``-DRT_PACK_WIDTH=8``,
    ``-DCMAKE_CXX_FLAGS=...``); ``cxx`` names the C++ compiler (None: CMake's choice). About
    a minute on two cores. Raises ``FileNotFoundError`` where cmake is missing and
    ``RuntimeError`` (with the end of the log) where a step fails.
    """
    if shutil.which("cmake") is None:
        raise FileNotFoundError("cmake is not installed")
    build_dir = Path(build_dir)
    configure = ["cmake", "-S", str(ROOT), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
                 f"-DPython_EXECUTABLE={sys.executable}", *cmake_args]
    if cxx is not None:
        configure.append(f"-DCMAKE_CXX_COMPILER={cxx}")
    for command in (configure, ["cmake", "--build", str(build_dir), "--target", "_core", "-j", str(int(jobs))]):
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"{shlex.join(command)} failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    return next(build_dir.glob("_core*.so"))


def run_with_core(module: Path, script: str, **values) -> str:
    """Run ``script`` in a fresh interpreter whose core is ``module`` (:func:`~reference_tracer.build.use_core`);
    return its stdout. Each ``values`` key in the script is replaced by the value's repr.
    Raises ``RuntimeError`` with the script's stderr where it fails."""
    body = script
    for key, value in values.items():
        body = body.replace(key, repr(value))
    code = _PREAMBLE.format(root=str(ROOT), module=str(module)) + body
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1"))
    if out.returncode != 0:
        raise RuntimeError(f"a run with {module} failed:\n{out.stderr[-3000:]}")
    return out.stdout


def agreement_arrays(module: Path, path: Path, *, threads: int = 2):
    """The arrays of :data:`AGREEMENT_SCRIPT` rendered by ``module``, saved to ``path``
    (``.npz``) and loaded (``numpy.lib.npyio.NpzFile``: a mapping of name to array)."""
    run_with_core(module, AGREEMENT_SCRIPT, PATH=str(path), THREADS=int(threads))
    return np.load(path)


def build_target(build_dir: Path) -> str:
    """What a build targeted: the macros simd.h reads (AVX2, FMA, AVX-512), from the build's
    own compiler and flags (CMake's cache and ``flags.make``), and the pack width they give
    (``RT_PACK_WIDTH`` where set, else simd.h's rule: 8 with AVX-512, 4 otherwise)."""
    build_dir = Path(build_dir)
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


# A worker that renders on request with its own core: reads "scene spp" lines, answers each
# with the wall seconds of one render (SIZE x SIZE, `mis`, wavefront, Russian roulette from
# depth 5 as Mitsuba's default, 1 thread). The caller's first render of a scene warms it up.
_RENDER_WORKER = """
import time
import reference_tracer as rt
from mitsuba_scenes import get_scene
scenes = {}
for line in sys.stdin:
    name, spp = line.split()
    if name not in scenes:
        scenes[name] = get_scene(name, width=SIZE, height=SIZE, max_depth=50, rr_depth=5)
    t0 = time.perf_counter()
    rt.render(scenes[name], spp=int(spp), strategy="mis", seed=1, threads=1)
    print(time.perf_counter() - t0, flush=True)
"""

# A worker that casts rays on request: reads "triangles kind count" lines, answers each with
# the wall seconds of one closest-hit query of `count` rays of `kind` (random / primary, as
# `rtbench speed --rays` makes them) on the benchmark's torus, like for like
# (`preliminary=True`), 1 thread. Meshes and rays are made once, on first request.
_RAY_WORKER = """
import time
import numpy as np
from benchmarks.speed.rays import mesh_scene, primary_rays, random_rays
from reference_tracer.probe import core_scene
meshes, rays = {}, {}
for line in sys.stdin:
    triangles, kind, count = line.split()
    if triangles not in meshes:
        meshes[triangles] = core_scene(mesh_scene(int(triangles)))
    if (kind, count) not in rays:
        o, d = (random_rays if kind == "random" else primary_rays)(int(count))
        rays[kind, count] = (np.ascontiguousarray(o, dtype=np.float64), np.ascontiguousarray(d, dtype=np.float64))
    o, d = rays[kind, count]
    t0 = time.perf_counter()
    meshes[triangles].intersect(o, d, threads=1, preliminary=True)
    print(time.perf_counter() - t0, flush=True)
"""


def _paired_times(modules, worker_script: str, requests, *, rounds: int) -> dict:
    """``{request: [[seconds of each module] per round]}`` for each request line, from one
    persistent worker per module running ``worker_script`` (it answers each request line
    with seconds), one request at a time, each round in turn starting with the next
    module; one untimed warm-up request per module first."""
    if rounds < 1:
        raise ValueError("rounds must be at least 1")

    workers, errors = [], []
    try:
        for module in modules:
            code = _PREAMBLE.format(root=str(ROOT), module=str(module)) + worker_script
            # stderr to a file: a pipe nobody reads while the worker runs could fill and stall it.
            errors.append(tempfile.TemporaryFile(mode="w+"))
            workers.append(subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                            stderr=errors[-1], text=True, cwd=ROOT,
                                            env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1", OPENBLAS_NUM_THREADS="1")))

        def ask(k, request):
            w = workers[k]
            w.stdin.write(f"{request}\n")
            w.stdin.flush()
            line = w.stdout.readline()
            if not line:
                w.wait(timeout=60)
                errors[k].seek(0)
                raise RuntimeError(f"the worker of {modules[k]} stopped:\n{errors[k].read()[-3000:]}")
            return float(line)

        times = {}
        for request in requests:
            for k in range(len(workers)):
                ask(k, request)  # warm-up
            rows = []
            for r in range(rounds):
                row = [0.0] * len(workers)
                for j in range(len(workers)):
                    k = (r + j) % len(workers)
                    row[k] = ask(k, request)
                rows.append(row)
            times[request] = rows
        return times
    finally:
        for w in workers:
            if w.stdin:
                w.stdin.close()
            try:
                w.wait(timeout=60)
            except subprocess.TimeoutExpired:
                w.kill()
                w.wait()
        for f in errors:
            f.close()


def paired_render_times(modules, scenes, *, rounds: int = 40, spp: int = 16, size: int = 128) -> dict:
    """Render times of several core builds, paired: ``{scene: [[seconds of each module] per round]}``.

    One persistent worker process per module renders on request, one render at a time
    (never two at once), each round in turn starting with the next module. Renders a
    fraction of a second apart see the same machine, so the per-round ratios cancel the
    slow drifts of a shared VM that separate timed processes do not (PERFORMANCE.md, How to
    measure: identical builds give a 90% interval of +-1% in 40 pairs, where best-of-six
    processes leave quartiles of +-5-20%).
    """
    times = _paired_times(modules, _RENDER_WORKER.replace("SIZE", str(int(size))),
                          [f"{scene} {int(spp)}" for scene in scenes], rounds=rounds)
    return {scene: times[f"{scene} {int(spp)}"] for scene in scenes}


def paired_ray_times(modules, triangles, kinds, *, rounds: int = 40, rays: int = 1 << 18) -> dict:
    """Ray-query times of several core builds, paired as :func:`paired_render_times` pairs
    renders: ``{(triangles, kind): [[seconds of each module] per round]}``, each a closest-hit
    query (``preliminary=True``, 1 thread) of ``rays`` rays of ``kind`` (``"random"`` or
    ``"primary"``, :mod:`benchmarks.speed.rays`) on the torus of ``triangles`` triangles."""
    for kind in kinds:
        if kind not in ("random", "primary"):
            raise ValueError(f"kind must be 'random' or 'primary', not {kind!r}")
    keys = [(int(t), kind) for t in triangles for kind in kinds]
    times = _paired_times(modules, _RAY_WORKER, [f"{t} {kind} {int(rays)}" for t, kind in keys], rounds=rounds)
    return {(t, kind): times[f"{t} {kind} {int(rays)}"] for t, kind in keys}


def median_interval(ratios, *, level: float = 0.90, resamples: int = 2000, seed: int = 0):
    """Median of ``ratios`` and a bootstrap interval of it (percentiles of the medians of
    ``resamples`` resamples with replacement, fixed ``seed``): ``(median, low, high)``.

    Examples
    --------
    >>> median_interval([1.0, 1.0, 1.0])
    (1.0, 1.0, 1.0)
    """
    x = np.asarray(ratios, dtype=float)
    if x.size == 0 or not np.all(np.isfinite(x)):
        raise ValueError("ratios must be finite and not empty")
    rng = np.random.default_rng(seed)
    medians = np.median(x[rng.integers(0, x.size, size=(resamples, x.size))], axis=1)
    tail = (1.0 - level) / 2.0
    return float(np.median(x)), float(np.quantile(medians, tail)), float(np.quantile(medians, 1.0 - tail))
