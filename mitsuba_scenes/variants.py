"""Mitsuba variant selection: the one place that picks and sets a Mitsuba variant.

The fastest working variant of ``cuda_ad_rgb``, ``llvm_ad_rgb`` and ``scalar_rgb`` is
chosen, unless the caller names one (argument) or the environment does
(``RTBENCH_MITSUBA_VARIANT``). ``llvm_ad_rgb`` needs a libLLVM that Dr.Jit can drive
(LLVM >= 16; LLVM 15 crashes it): this module looks for one, preferring LLVM 19, and
sets ``DRJIT_LIBLLVM_PATH`` before Dr.Jit is imported. Because a bad libLLVM can
segfault the process, each JIT variant is first tried in a subprocess (a tiny render);
the verdict is cached for the life of the process. When the automatic choice falls
back to ``scalar_rgb``, one log line (``logging``, logger ``mitsuba_scenes.variants``)
says why.

Examples
--------
>>> from mitsuba_scenes.variants import select_variant, versions
>>> select_variant("scalar_rgb")
'scalar_rgb'
>>> versions()["variant"]
'scalar_rgb'
"""
from __future__ import annotations

import ctypes
import glob
import importlib.util
import logging
import os
import re
import subprocess
import sys

__all__ = ["VARIANT_ENV", "PREFERRED_VARIANTS", "select_variant", "import_mitsuba",
           "find_libllvm", "probe_variant", "versions", "llvm_target", "set_llvm_target"]

log = logging.getLogger(__name__)

#: Environment variable that overrides the automatic choice.
VARIANT_ENV = "RTBENCH_MITSUBA_VARIANT"
#: Candidates, fastest first.
PREFERRED_VARIANTS = ("cuda_ad_rgb", "llvm_ad_rgb", "scalar_rgb")
#: Dr.Jit cannot run on these LLVM major versions (15 crashes Mitsuba's llvm_ad_rgb).
MIN_LLVM_MAJOR = 16
PREFERRED_LLVM_MAJOR = 19

_PROBE_TIMEOUT_S = 180
_probe_cache: dict = {}       # variant -> (ok: bool, reason: str)
_state: dict = {"variant": None, "logged": False, "libllvm": None}

_PROBE_CODE = r"""
import sys
import mitsuba as mi
mi.set_variant(sys.argv[1])
scene = mi.load_dict({
    "type": "scene", "integrator": {"type": "path", "max_depth": 3},
    "sensor": {"type": "perspective", "fov": 45,
               "film": {"type": "hdrfilm", "width": 4, "height": 4, "rfilter": {"type": "box"}}},
    "sphere": {"type": "sphere", "center": [0, 0, 5], "radius": 1.0},
    "light": {"type": "constant"}})
img = mi.render(scene, spp=4, seed=1)
import numpy as np
a = np.array(img)
assert a.shape == (4, 4, 3) and np.all(np.isfinite(a)), a
print("RTBENCH_PROBE_OK")
"""


def _llvm_major(path: str) -> int | None:
    name = os.path.basename(path)
    for pat in (r"libLLVM-(\d+)", r"libLLVM\.so\.(\d+)", r"llvm-(\d+)", r"llvm@(\d+)"):
        m = re.search(pat, name) or re.search(pat, path)
        if m:
            return int(m.group(1))
    return None


def find_libllvm() -> list:
    """Candidate libLLVM shared libraries usable by Dr.Jit, best first.

    Looks in the usual system and conda locations and keeps those whose major
    version is >= 16, ordering LLVM 19 first, then newer, then older. An explicit
    ``DRJIT_LIBLLVM_PATH`` set by the user comes first whatever its version.

    Returns
    -------
    list of str

    Examples
    --------
    >>> paths = find_libllvm()  # e.g. ['/usr/lib/x86_64-linux-gnu/libLLVM-19.so']
    """
    patterns = ["/usr/lib/x86_64-linux-gnu/libLLVM*.so*", "/usr/lib/aarch64-linux-gnu/libLLVM*.so*",
                "/usr/lib/llvm-*/lib/libLLVM*.so*", "/usr/lib64/libLLVM*.so*",
                "/usr/local/lib/libLLVM*.so*", "/opt/homebrew/opt/llvm*/lib/libLLVM*.dylib",
                "/usr/local/opt/llvm*/lib/libLLVM*.dylib"]
    if os.environ.get("CONDA_PREFIX"):
        patterns.append(os.path.join(os.environ["CONDA_PREFIX"], "lib", "libLLVM*.so*"))
    seen, found = set(), []
    for pat in patterns:
        for p in sorted(glob.glob(pat)):
            real = os.path.realpath(p)
            if real in seen or not os.path.isfile(real):
                continue
            major = _llvm_major(p)
            if major is None or major < MIN_LLVM_MAJOR:
                continue
            seen.add(real)
            found.append((major, p))
    found.sort(key=lambda mp: (mp[0] != PREFERRED_LLVM_MAJOR, -mp[0], len(mp[1])))
    out = [p for _, p in found]
    user = os.environ.get("DRJIT_LIBLLVM_PATH")
    if user:
        out = [user] + [p for p in out if os.path.realpath(p) != os.path.realpath(user)]
    return out


def probe_variant(variant: str, *, libllvm: str | None = None) -> tuple:
    """Try ``variant`` in a subprocess with a tiny render; return ``(ok, reason)``.

    The verdict is cached per process (key: variant and libLLVM path).

    Examples
    --------
    >>> probe_variant("scalar_rgb")[0]
    True
    """
    key = (variant, libllvm)
    if key in _probe_cache:
        return _probe_cache[key]
    env = dict(os.environ)
    if libllvm:
        env["DRJIT_LIBLLVM_PATH"] = libllvm
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE_CODE, variant], env=env,
                              capture_output=True, text=True, timeout=_PROBE_TIMEOUT_S)
        ok = proc.returncode == 0 and "RTBENCH_PROBE_OK" in proc.stdout
        if ok:
            reason = "ok"
        else:
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or [""]
            reason = f"exit code {proc.returncode}: {tail[0][:200]}"
    except subprocess.TimeoutExpired:
        ok, reason = False, f"probe timed out after {_PROBE_TIMEOUT_S} s"
    _probe_cache[key] = (ok, reason)
    return ok, reason


def _compiled_variants() -> list:
    """Variants compiled into the installed Mitsuba, read from its package files.

    Importing ``mitsuba`` would import Dr.Jit, which reads ``DRJIT_LIBLLVM_PATH`` at
    import time; so this looks at the files instead.
    """
    mod = sys.modules.get("mitsuba")
    origin = getattr(mod, "__file__", None) if mod is not None else None
    if origin is None:
        spec = importlib.util.find_spec("mitsuba")
        origin = spec.origin if spec is not None else None
    if origin is None:
        raise RuntimeError("Mitsuba 3 is not installed (pip install mitsuba)")
    names = set()
    for folder in [os.path.dirname(origin)]:
        for f in os.listdir(folder):
            m = re.match(r"((?:scalar|llvm|cuda)\w*?)\.(?:cpython|abi3|pyd|so)", f)
            if m and m.group(1) != "mitsuba_ext":
                names.add(m.group(1))
    order = {"scalar": 0, "llvm": 1, "cuda": 2}
    return sorted(names, key=lambda n: (order.get(n.split("_")[0], 3), n))


def _try_llvm() -> tuple:
    """(libllvm path or None, reason) for a working llvm_ad_rgb."""
    if "drjit" in sys.modules:
        # Dr.Jit already read DRJIT_LIBLLVM_PATH (or searched by default) when it was
        # imported; only that configuration can be probed now.
        current = os.environ.get("DRJIT_LIBLLVM_PATH")
        ok, why = probe_variant("llvm_ad_rgb", libllvm=current)
        return (current or "default", "ok") if ok else (None, f"{current or 'default libLLVM'}: {why}")
    reasons = []
    for path in find_libllvm():
        ok, why = probe_variant("llvm_ad_rgb", libllvm=path)
        if ok:
            return path, "ok"
        reasons.append(f"{path}: {why}")
    if not reasons:
        return None, f"no libLLVM >= {MIN_LLVM_MAJOR} found"
    return None, "; ".join(reasons)


def _set_libllvm(path: str | None) -> None:
    if path is None or path == "default":
        _state["libllvm"] = os.environ.get("DRJIT_LIBLLVM_PATH", "default")
        return
    if "drjit" in sys.modules and os.environ.get("DRJIT_LIBLLVM_PATH") != path:
        # Dr.Jit reads the variable when its LLVM backend starts; a late change may be ignored.
        log.debug("drjit already imported; setting DRJIT_LIBLLVM_PATH=%s may come too late", path)
    os.environ["DRJIT_LIBLLVM_PATH"] = path
    _state["libllvm"] = path


def select_variant(variant: str | None = None) -> str:
    """Pick, set (``mi.set_variant``) and return the Mitsuba variant.

    Parameters
    ----------
    variant : str or None
        A variant name to force. None reads ``RTBENCH_MITSUBA_VARIANT``; if that is
        unset too, the fastest working one of ``cuda_ad_rgb``, ``llvm_ad_rgb``,
        ``scalar_rgb`` is chosen (JIT variants are probed once per process in a
        subprocess). A variant named explicitly (argument or environment) that does
        not work raises ``RuntimeError``; only the automatic choice falls back.

    Returns
    -------
    str
        The variant now active.

    Examples
    --------
    >>> select_variant("scalar_rgb")
    'scalar_rgb'
    """
    requested = variant if variant is not None else (os.environ.get(VARIANT_ENV) or None)
    if requested is None and _state["variant"] is not None:
        _activate(_state["variant"])
        return _state["variant"]
    if requested is not None:
        if not isinstance(requested, str) or not requested.endswith("_rgb"):
            raise ValueError(f"Mitsuba variant must be an RGB variant such as 'scalar_rgb', "
                             f"'llvm_ad_rgb' or 'cuda_ad_rgb', got {requested!r}")
        if requested not in _compiled_variants():
            raise ValueError(f"Mitsuba variant {requested!r} is not compiled in this Mitsuba; "
                             f"available: {_compiled_variants()}")
        if requested.startswith("llvm"):
            path, why = _try_llvm()
            if path is None:
                raise RuntimeError(f"Mitsuba variant {requested!r} does not work here ({why}); "
                                   f"use 'scalar_rgb' or install libLLVM >= {MIN_LLVM_MAJOR}")
            _set_libllvm(path)
        elif requested.startswith("cuda"):
            ok, why = probe_variant(requested)
            if not ok:
                raise RuntimeError(f"Mitsuba variant {requested!r} does not work here ({why})")
        chosen = requested
    else:
        chosen, notes = None, []
        available = _compiled_variants()
        if "cuda_ad_rgb" in available:
            ok, why = probe_variant("cuda_ad_rgb")
            if ok:
                chosen = "cuda_ad_rgb"
            else:
                notes.append(f"cuda_ad_rgb: {why}")
        if chosen is None and "llvm_ad_rgb" in available:
            path, why = _try_llvm()
            if path is not None:
                _set_libllvm(path)
                chosen = "llvm_ad_rgb"
            else:
                notes.append(f"llvm_ad_rgb: {why}")
        if chosen is None:
            chosen = "scalar_rgb"
            log.warning("Mitsuba: no working JIT variant (%s); falling back to scalar_rgb "
                        "(slower, CPU only)", "; ".join(notes) or "none compiled")
            _state["logged"] = True
    _activate(chosen)
    if not _state["logged"]:
        log.info("Mitsuba variant: %s%s", chosen,
                 f" (libLLVM {_state['libllvm']})" if chosen.startswith("llvm") else "")
        _state["logged"] = True
    if variant is None and os.environ.get(VARIANT_ENV) is None:
        _state["variant"] = chosen
    return chosen


def _activate(name: str) -> None:
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    if mi.variant() != name:
        mi.set_variant(name)


def import_mitsuba(variant: str | None = None):
    """Return the ``mitsuba`` module with a variant set.

    If a variant is already active and ``variant`` is None, it is kept; otherwise
    :func:`select_variant` chooses one.

    Examples
    --------
    >>> mi = import_mitsuba("scalar_rgb")
    >>> mi.variant()
    'scalar_rgb'
    """
    if variant is None:
        import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

        if mi.variant() is not None:
            return mi
    select_variant(variant)
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    return mi


def versions() -> dict:
    """Versions for results records: Mitsuba, Dr.Jit, the active variant, libLLVM, and the
    LLVM backend's target (:func:`llvm_target`, None where that backend has not run).

    Examples
    --------
    >>> sorted(versions())
    ['drjit', 'libllvm', 'llvm_target', 'mitsuba', 'variant']
    """
    import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    variant = mi.variant()
    return {"mitsuba": mi.__version__, "drjit": dr.__version__, "variant": variant,
            "libllvm": os.environ.get("DRJIT_LIBLLVM_PATH") if variant and variant.startswith("llvm") else None,
            "llvm_target": llvm_target()}


# Dr.Jit's C++ functions that report the LLVM backend's target (drjit-core's jit.h:
# jit_llvm_target_cpu, jit_llvm_vector_width), by their mangled names: the Python bindings
# do not expose them. Itanium-ABI names of functions without arguments, stable while the
# signatures are.
_LLVM_TARGET_SYMBOLS = {"cpu": "_Z19jit_llvm_target_cpuv", "width": "_Z21jit_llvm_vector_widthv",
                        "features": "_Z24jit_llvm_target_featuresv",
                        # jit_llvm_set_target(const char *cpu, const char *features, uint32_t width)
                        "set": "_Z19jit_llvm_set_targetPKcS0_j"}


def _drjit_core():
    """Dr.Jit's core library (already loaded by ``import drjit``); OSError where it is not there."""
    import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)

    return ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))


def llvm_target() -> dict | None:
    """The CPU and vector width that Dr.Jit's LLVM backend compiles kernels for, in this process.

    Dr.Jit chooses them when its LLVM backend starts, from the running CPU: 8 float lanes
    with AVX2, 16 with AVX-512. It sets the speed of ``llvm_ad_rgb`` (PERFORMANCE.md, How to
    measure: 1.1-1.7x between the two on one CPU). This asks Dr.Jit itself; ``mitsuba --help``'s
    "8-wide SIMD" line stands beside the processor features Mitsuba's binary was compiled
    for, so it is not taken as the JIT's choice.

    Returns
    -------
    dict or None
        ``cpu`` (LLVM's name, e.g. ``'znver3'``), ``vector_width`` (float lanes per kernel
        instruction) and ``avx512`` (bool); None where the LLVM backend has not started in
        this process or this Dr.Jit does not export the functions.

    Examples
    --------
    >>> target = llvm_target()
    >>> target is None or target["vector_width"] in (4, 8, 16)
    True
    """
    try:
        core = _drjit_core()
        cpu, width, features = (core[_LLVM_TARGET_SYMBOLS[k]] for k in ("cpu", "width", "features"))
    except (OSError, AttributeError):
        return None
    cpu.restype = features.restype = ctypes.c_char_p
    width.restype = ctypes.c_uint32
    lanes, name, flags = int(width()), cpu(), features()
    if lanes == 0 or not name:
        return None
    return {"cpu": name.decode(), "vector_width": lanes,
            "avx512": "+avx512f" in (flags or b"").decode().split(",")}


def set_llvm_target(cpu: str, features: str, vector_width: int) -> dict:
    """Make Dr.Jit's LLVM backend compile the kernels of this process for another CPU.

    ``llvm_ad_rgb`` compiles its kernels for the running CPU (:func:`llvm_target`). A machine
    with AVX-512 can run the kernels a machine with AVX2 only would get (``'haswell'``, its
    features, 8 lanes), so that a build of ours for AVX2 is timed against Mitsuba as a laptop
    runs it. The target holds for the rest of the process, which must not have run a kernel
    yet: a scene loaded at one width and rendered at another comes out black or crashes the
    process, so the call is refused after the first kernel launch (every scene load makes
    some). Embree, inside Mitsuba, keeps choosing its own instruction set from the CPU.

    Parameters
    ----------
    cpu : str
        LLVM's name of the CPU (``'haswell'``, ``'skylake-avx512'``).
    features : str
        LLVM's comma-separated feature flags (``'+avx2,+fma'``); they must be a subset of the
        running CPU's, which the caller checks.
    vector_width : int
        Float lanes a kernel instruction: 4, 8 or 16.

    Returns
    -------
    dict
        :func:`llvm_target` after the change.

    Raises
    ------
    ValueError
        For a width other than 4, 8 or 16, or an empty CPU name.
    RuntimeError
        Where the LLVM variant is not the active one, a kernel has run in this process, this
        Dr.Jit does not export the function, or the backend did not take the target.

    Examples
    --------
    >>> select_variant("llvm_ad_rgb")  # doctest: +SKIP
    >>> set_llvm_target("haswell", "+avx,+avx2,+fma", 8)["vector_width"]  # doctest: +SKIP
    8
    """
    if vector_width not in (4, 8, 16) or isinstance(vector_width, bool):
        raise ValueError(f"vector_width must be 4, 8 or 16, got {vector_width!r}")
    if not cpu:
        raise ValueError("cpu must name an LLVM CPU, e.g. 'haswell'")
    import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    if not (mi.variant() or "").startswith("llvm"):
        raise RuntimeError(f"an LLVM target needs an llvm variant active, not {mi.variant()!r}")
    launches = re.search(r"Kernel launches\s*:\s*(\d+)", dr.whos(True) or "")
    if launches is None or int(launches.group(1)) != 0:
        raise RuntimeError("an LLVM target must be set before this process runs any Dr.Jit kernel (load or render): "
                           + ("Dr.Jit did not report its kernel launches" if launches is None else
                              f"{launches.group(1)} have run, at {(llvm_target() or {}).get('vector_width')} lanes"))
    try:
        setter = _drjit_core()[_LLVM_TARGET_SYMBOLS["set"]]
    except (OSError, AttributeError):
        raise RuntimeError(f"Dr.Jit {dr.__version__} does not export jit_llvm_set_target") from None
    setter.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    setter.restype = None
    setter(cpu.encode(), features.encode(), int(vector_width))
    now = llvm_target()
    if now is None or now["cpu"] != cpu or now["vector_width"] != vector_width:
        raise RuntimeError(f"Dr.Jit's LLVM backend did not take the target {cpu}, {vector_width} lanes (now {now})")
    return now
