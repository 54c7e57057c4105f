"""Other builds of the C++ core beside the installed one: :func:`build_core`, :func:`build_isa` (:data:`ISAS`), and
code run against a build in a fresh interpreter (:func:`run_with_core`, :class:`CoreWorker`). Every build must give the
same images bit for bit (:data:`AGREEMENT_SCRIPT`); :func:`paired_times` times builds against each other
(``scripts/ab_cores.py``; PERFORMANCE.md, How to measure)."""
from __future__ import annotations

import contextlib
import os
import pickle
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["ROOT", "ISAS", "MITSUBA_TARGETS", "mitsuba_isas", "AGREEMENT_SCRIPT", "cpu_flags", "build_core",
           "build_isa", "run_with_core", "agreement_arrays", "build_target", "CoreWorker", "paired_times"]

#: The repository's root (the CMake project).
ROOT = Path(__file__).resolve().parents[2]

_V3 = frozenset({"avx", "avx2", "bmi1", "bmi2", "f16c", "fma", "movbe", "abm", "xsave"})
#: Instruction sets a build can target: its ``-march`` level and the CPU flags (as /proc/cpuinfo names them) that
#: GCC's and Clang's level assumes: a build runs only where the CPU has them all.
ISAS = {"avx2": ("x86-64-v3", _V3),
        "avx512": ("x86-64-v4", _V3 | {"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"})}

_V3_LLVM = "+avx,+avx2,+bmi,+bmi2,+cx16,+f16c,+fma,+lzcnt,+movbe,+popcnt,+sse,+sse2,+sse3,+sse4.1,+sse4.2,+ssse3,+xsave"
#: What Dr.Jit's LLVM backend compiles Mitsuba's kernels for on a CPU of each instruction set (its CPU name, feature
#: flags and float lanes: ``mitsuba_scenes.variants.set_llvm_target``), so that a build of ours for an ISA is timed
#: against Mitsuba as a machine of that ISA runs it.
MITSUBA_TARGETS = {"avx2": ("haswell", _V3_LLVM, 8),
                   "avx512": ("skylake-avx512", _V3_LLVM + ",+avx512f,+avx512bw,+avx512cd,+avx512dq,+avx512vl", 16)}


def mitsuba_isas(builds, native) -> list:
    """The ``builds`` (named by their ISA) whose Mitsuba kernels have another width than this CPU's (``native``:
    ``mitsuba_scenes.variants.llvm_target()``; None, no LLVM backend: none): against these, Mitsuba runs with
    kernels for the build's ISA (:data:`MITSUBA_TARGETS`). On a CPU of the ISA itself, Mitsuba's own kernels are
    already the ISA's."""
    return [b for b in builds
            if b in MITSUBA_TARGETS and native is not None and native["vector_width"] != MITSUBA_TARGETS[b][2]]


_ENV = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", OPENBLAS_NUM_THREADS="1")

# Makes `module` the fresh interpreter's core before anything loads it.
_PREAMBLE = """
import sys
sys.path.insert(0, {root!r})
from reference_tracer.build import use_core
use_core({module!r})
"""

#: What every build must give bit for bit (PATH: the .npz written, THREADS: compared with one thread): each suite
#: scene x strategy x integrator at 16x12, 4 spp; a 64x48 ``cornell_box`` rendered with 1 and THREADS threads; the
#: closest hits of 4096 random rays on a 20k-triangle mesh.
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

# A worker's loop: call the function each request names with its (pickled) arguments, answer (True, result) or (False,
# traceback). Its stdout carries the answers alone: whatever else Python or C code writes there goes to stderr.
_SERVE = """
import importlib, os, pickle, traceback
answers = os.fdopen(os.dup(1), "wb")
os.dup2(2, 1)
while True:
    try:
        name, args, kwargs = pickle.load(sys.stdin.buffer)
    except EOFError:
        break
    module, _, function = name.rpartition(".")
    try:
        answer = (True, getattr(importlib.import_module(module), function)(*args, **kwargs))
    except Exception:
        answer = (False, traceback.format_exc())
    pickle.dump(answer, answers)
    answers.flush()
"""


def cpu_flags() -> frozenset:
    """The CPU's feature flags as Linux lists them (empty where /proc/cpuinfo is absent)."""
    try:
        with open("/proc/cpuinfo") as f:
            return next((frozenset(line.split(":", 1)[1].split()) for line in f if line.startswith("flags")),
                        frozenset())
    except OSError:
        return frozenset()


def build_core(build_dir: Path, *cmake_args: str, cxx: str | None = None, jobs: int = 2) -> Path:
    """Configure and build the ``_core`` target into ``build_dir`` (brought up to date if built before); the module.

    ``cmake_args``: extra CMake arguments (``-DRT_NATIVE=OFF``, ``-DRT_PACK_WIDTH=8``, ...); ``cxx``: the C++ compiler
    (None: CMake's). About a minute on two cores. ``FileNotFoundError`` without cmake, ``RuntimeError`` (with the
    log's end) where a step fails.
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


def build_isa(isa: str, build_dir: Path, *, jobs: int = 2) -> Path:
    """Build the core for ``isa`` (``-march`` its level of :data:`ISAS`) into ``build_dir``; the module's path.
    ``ValueError`` where this CPU cannot run it (a flag missing from /proc/cpuinfo), else as :func:`build_core`."""
    march, needs = ISAS[isa]
    missing = sorted(needs - cpu_flags())
    if missing:
        raise ValueError(f"this CPU cannot run an {isa} build (-march={march}): /proc/cpuinfo lists no "
                         f"{', '.join(missing)}")
    return build_core(build_dir, "-DRT_NATIVE=OFF", f"-DCMAKE_CXX_FLAGS=-march={march}", jobs=jobs)


def run_with_core(module: Path, script: str, **values) -> str:
    """Run ``script`` in a fresh interpreter whose core is ``module``, each ``values`` key in it replaced by the
    value's repr; its stdout. ``RuntimeError`` with the script's stderr where it fails."""
    body = script
    for key, value in values.items():
        body = body.replace(key, repr(value))
    code = _PREAMBLE.format(root=str(ROOT), module=str(module)) + body
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=_ENV)
    if out.returncode != 0:
        raise RuntimeError(f"a run with {module} failed:\n{out.stderr[-3000:]}")
    return out.stdout


def agreement_arrays(module: Path, path: Path, *, threads: int = 2):
    """The arrays of :data:`AGREEMENT_SCRIPT` rendered by ``module``, saved to ``path`` (``.npz``) and loaded."""
    run_with_core(module, AGREEMENT_SCRIPT, PATH=str(path), THREADS=int(threads))
    return np.load(path)


def build_target(build_dir: Path) -> str:
    """What a build targeted: the macros simd.h reads (AVX2, FMA, AVX-512) from the build's own compiler and flags,
    and the pack width they give (``RT_PACK_WIDTH`` where set, else 8 with AVX-512, 4 otherwise)."""
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


class CoreWorker:
    """A persistent interpreter whose core is ``module`` (a context manager): ``worker("pkg.module.function", *args,
    **kwargs)`` calls that function there and returns its result (both pickled); ``RuntimeError`` with the worker's
    traceback or stderr where the call fails or the worker stops."""

    def __init__(self, module):
        self.module = Path(module)
        # stderr to a file: a pipe nobody reads while the worker runs could fill and stall it.
        self._stderr = tempfile.TemporaryFile(mode="w+")
        code = _PREAMBLE.format(root=str(ROOT), module=str(self.module)) + _SERVE
        self._process = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=self._stderr, cwd=ROOT, env=_ENV)

    def __call__(self, function: str, *args, **kwargs):
        try:
            pickle.dump((function, args, kwargs), self._process.stdin)
            self._process.stdin.flush()
            ok, answer = pickle.load(self._process.stdout)
        except (EOFError, BrokenPipeError):
            self._process.wait(timeout=60)
            self._stderr.seek(0)
            raise RuntimeError(f"the worker of {self.module} stopped:\n{self._stderr.read()[-3000:]}") from None
        if not ok:
            raise RuntimeError(f"{function} failed with the core {self.module}:\n{answer[-3000:]}")
        return answer

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._process.stdin.close()
        try:
            self._process.wait(timeout=60)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._stderr.close()


def paired_times(modules, requests: dict, *, rounds: int = 40, seconds=float) -> dict:
    """Times of several core builds, paired: ``{key: [[seconds of each module] per round]}``.

    ``requests`` maps a key to ``(function, kwargs)``, a function a :class:`CoreWorker` of each module calls, whose
    answer ``seconds`` turns into seconds. One call at a time, each round starting with the next module, after an
    untimed call each: calls a fraction of a second apart see the same machine, so the per-round ratios cancel the
    drifts of a shared VM that separate processes do not (PERFORMANCE.md, How to measure).
    """
    with contextlib.ExitStack() as stack:
        workers = [stack.enter_context(CoreWorker(m)) for m in modules]
        times = {}
        for key, (function, kwargs) in requests.items():
            for worker in workers:
                worker(function, **kwargs)   # warm-up
            times[key] = []
            for r in range(rounds):
                row = [0.0] * len(workers)
                for j in range(len(workers)):
                    k = (r + j) % len(workers)
                    row[k] = seconds(workers[k](function, **kwargs))
                times[key].append(row)
        return times

