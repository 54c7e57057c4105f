"""One scene of a corpus, judged on the unmodified file (:func:`judge_scene`, in the worker
process): its ``$name`` parameters given values, Mitsuba loads it and we import it with the
film made small (:func:`small_film`), both render it and
:func:`benchmarks.gate.agreement.agreement` judges the pair. The status is the first of
``out-of-scope`` (a plugin of :data:`OUT_OF_SCOPE`, or spectral-only data),
``mitsuba-fails``, ``refused``, ``render-error``, ``agrees`` / ``disagrees`` that applies.
"""
from __future__ import annotations

import math
import re
import time

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import from_mitsuba, render_mitsuba
from mitsuba_scenes.importer import UnsupportedSceneError
from mitsuba_scenes.render import file_resolver_scope, film_sizes, load_file
from mitsuba_scenes.variants import select_variant

from ..gate.agreement import SHARE_LIMIT, Z_LIMIT, agreement

__all__ = ["STATUSES", "OUT_OF_SCOPE", "OUT_OF_SCOPE_KINDS", "Z_LIMIT", "SHARE_LIMIT", "small_film",
           "out_of_scope", "compact_feature", "clean_message", "scene_plugins",
           "judge_scene", "setup", "cut"]

#: every status, in the order tables list them.
STATUSES = ("agrees", "disagrees", "render-error", "refused", "out-of-scope", "mitsuba-fails", "timeout")

#: plugins outside the tracer's scope (refused by name, not counted as missing features): name -> what.
OUT_OF_SCOPE = {
    "volpath": "participating media", "volpathmis": "participating media", "prbvolpath": "participating media",
    "homogeneous": "participating media", "heterogeneous": "participating media",
    "stokes": "polarisation", "pplastic": "polarisation", "polarizer": "polarisation",
    "measured_polarized": "polarisation", "retarder": "polarisation", "circular": "polarisation",
    "hair": "hair", "bsplinecurve": "hair (curves)", "linearcurve": "hair (curves)",
    "sdfgrid": "SDF grid", "aov": "AOV integrator", "ptracer": "particle tracer",
}
#: object kinds outside the scope whatever their plugin.
OUT_OF_SCOPE_KINDS = {"medium": "participating media", "phase": "participating media",
                      "volume": "participating media"}

_PLUGIN = re.compile(r"\b([a-z_]+) '([^']*)'")
_SPECTRAL = re.compile(r"spectral (variant|mode)|only (be used|supported) in spectral|requires a spectral", re.I)
_UNDEFINED = re.compile(r"undefined parameter: \$(\w+)")
_CPP_PREFIX = re.compile(r"\[[\w.]+\.(?:cpp|h):\d+\]\s*")
#: the most characters of a message kept in a record.
MAX_MESSAGE = 600


def small_film(width: int, height: int, max_width: int) -> tuple:
    """``(width, height)`` when at most ``max_width`` wide, else ``max_width`` wide with the aspect
    ratio kept (the height rounded, at least 1).

    >>> small_film(768, 512, 48), small_film(960, 720, 48), small_film(32, 32, 48)
    ((48, 32), (48, 36), (32, 32))
    """
    if width <= max_width:
        return int(width), int(height)
    return int(max_width), max(1, int(round(height * max_width / width)))


_FILE_TOKEN = re.compile(r"'?[^\s':]*\.(?:obj|ply|serialized|xml|exr|png|jpe?g|hdr|pfm|bmp|tga|spd|vol|m3hair)'?", re.I)


def compact_feature(feature: str) -> str:
    """A feature without its explanation (file names become ``FILE``; the text before ``" ("`` or
    ``": "``), so that scenes needing the same thing count together.

    >>> compact_feature("emitter 'envmap' (only 'area' on shapes and 'constant')")
    "emitter 'envmap'"
    >>> compact_feature("obj mesh a/b.obj cannot be used: [Errno 2] No such file or directory: 'a/b.obj'")
    'obj mesh FILE cannot be used'
    """
    text = _FILE_TOKEN.sub("FILE", feature)
    return text.split(" (", 1)[0].split(": ", 1)[0].strip() or feature


def out_of_scope(features, mitsuba_error: str | None = None, plugins=()) -> list:
    """The out-of-scope items among our refusal's ``features`` and the scene's ``plugins``
    (``(kind, name)`` pairs, nested ones included), and ``"spectral-only data: ..."`` when
    Mitsuba's error says it needs a spectral variant.

    >>> out_of_scope(["bsdf 'hair'", "emitter 'envmap' (only ...)"], plugins=[("integrator", "volpath")])
    ["hair: bsdf 'hair'", "participating media: integrator 'volpath'"]
    """
    out = []
    pairs = [pair for feature in features for pair in _PLUGIN.findall(feature)] + [tuple(p) for p in plugins]
    for kind, name in pairs:
        what = OUT_OF_SCOPE_KINDS.get(kind) or OUT_OF_SCOPE.get(name)
        if what:
            out.append(f"{what}: {kind} '{name}'")
    if mitsuba_error and _SPECTRAL.search(mitsuba_error):
        out.append(f"spectral-only data: {mitsuba_error}")
    return list(dict.fromkeys(out))


def clean_message(text, root=None) -> str:
    """One line of an error message without Mitsuba's ``[parser.cpp:451]`` tags and the folder
    ``root``, at most :data:`MAX_MESSAGE` characters."""
    s = " ".join(str(text).split())
    s = _CPP_PREFIX.sub("", s)
    if root:
        s = s.replace(str(root).rstrip("/") + "/", "")
    return cut(s, MAX_MESSAGE)


def cut(text: str, n: int) -> str:
    """``text`` cut to ``n`` characters, ``...`` marking a cut."""
    return text if len(text) <= n else text[:n - 3] + "..."


def setup(variant: str | None, threads: int | None) -> str:
    """Choose the Mitsuba variant (once per process) and the thread count; return the variant."""
    chosen = select_variant(variant)
    if threads:
        import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)

        dr.set_thread_count(int(threads))
    return chosen


def scene_plugins(mi, path, params) -> list:
    """Sorted distinct ``(kind, plugin)`` pairs of every object of the XML file (includes and
    nested objects too), as Mitsuba's parser reads them."""
    with file_resolver_scope():
        state = mi.parser.parse_file(mi.parser.ParserConfig(mi.variant()), str(path), **params)
    pairs = {(str(n.type).split(".")[-1].lower(), n.props.plugin_name()) for n in list(state.nodes)[1:]}
    return sorted(pairs)


def judge_scene(job: dict) -> dict:
    """The record of the scene of ``job`` (``path``, ``root``, ``spp``, ``batches``, ``seed``,
    ``width``, ``threads``)."""
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    t_start = time.perf_counter()
    root, path = job["root"], job["path"]
    rec = {"status": None, "reasons": [], "features": [], "params": {}, "variant": mi.variant()}
    seconds = rec["phase_seconds"] = {}
    backup = mi.file_resolver()
    mi.set_file_resolver(mi.FileResolver(backup))   # a scene's <path>s never reach the next scene
    try:
        _judge(job, rec, seconds, mi, root, path)
    finally:
        mi.set_file_resolver(backup)
        rec["seconds"] = round(time.perf_counter() - t_start, 3)
    return rec


def _judge(job, rec, seconds, mi, root, path) -> None:
    # 1. parameters the file leaves to its caller, its film and its plugins
    params, sizes, parse_error, plugins = {}, None, None, []
    t = time.perf_counter()
    for _ in range(16):
        try:
            sizes = film_sizes(path, params=params)
            plugins = scene_plugins(mi, path, params)
            break
        except Exception as exc:  # noqa: BLE001 - Mitsuba's parser raises RuntimeError
            m = _UNDEFINED.search(str(exc))
            if m and m.group(1) not in params:  # a sample count gets ours, anything else 1
                name = m.group(1).lower()
                params[m.group(1)] = str(job["spp"]) if "spp" in name or "sample" in name else "1"
                continue
            parse_error = exc
            break
    rec["params"] = params
    rec["plugins"] = [f"{k}:{n}" for k, n in plugins]
    size = None   # no <film> (Mitsuba's default 768x576): loaded and imported as it is, not rendered
    if sizes:
        rec["film_original"] = list(sizes[0])
        size = small_film(*sizes[0], job["width"])
        rec["film"] = list(size)

    # 2. Mitsuba loads it
    mitsuba_error = None
    if parse_error is not None:
        mitsuba_error = clean_message(parse_error, root)
    else:
        try:
            loaded = load_file(path, params=params, film_size=size)
            if not isinstance(loaded, mi.Scene):
                mitsuba_error = f"the file loads as a {type(loaded).__name__}, not a scene"
            del loaded
        except Exception as exc:  # noqa: BLE001 - any failure of Mitsuba's is the verdict
            mitsuba_error = clean_message(exc, root)
    seconds["mitsuba_load"] = round(time.perf_counter() - t, 3)
    if mitsuba_error:
        rec["mitsuba_error"] = mitsuba_error

    # 3. we import it
    t = time.perf_counter()
    scene, features, import_error, crash = None, [], None, None
    try:
        scene = from_mitsuba(path, params, film_size=size)
    except UnsupportedSceneError as exc:
        features = list(dict.fromkeys(clean_message(f, root) for f in exc.features))
    except ValueError as exc:
        import_error = clean_message(exc, root)
    except Exception as exc:  # noqa: BLE001 - an importer bug: reported, the run goes on
        crash = clean_message(f"from_mitsuba raised {type(exc).__name__}: {exc}", root)
    seconds["import"] = round(time.perf_counter() - t, 3)
    rec["features"] = features

    oos = out_of_scope(features, mitsuba_error, plugins if (features or mitsuba_error or import_error) else ())
    no_film = "no <film> whose size could be set (Mitsuba's default film is 768x576): not rendered"
    for status, reasons in (("out-of-scope", oos), ("mitsuba-fails", [mitsuba_error] if mitsuba_error else []),
                            ("refused", features or ([import_error] if import_error else [])),
                            ("render-error", [crash] if crash else []),
                            ("render-error", [no_film] if size is None else [])):
        if reasons:
            rec["status"], rec["reasons"] = status, reasons
            return

    # 4. both render it
    spp, seed, threads = int(job["spp"]), int(job["seed"]), job.get("threads")
    try:
        t = time.perf_counter()
        ours = rt.render(scene, spp=spp, strategy="mis", seed=seed, threads=threads)
        seconds["ours"] = round(time.perf_counter() - t, 3)
        t = time.perf_counter()
        mit = render_mitsuba(path, spp=spp, seed=seed, batches=int(job["batches"]), params=params,
                             threads=threads, film_size=size, variant=mi.variant())
        seconds["mitsuba"] = round(time.perf_counter() - t, 3)
    except Exception as exc:  # noqa: BLE001 - a render that fails is this scene's result
        rec["status"], rec["reasons"] = "render-error", [clean_message(f"{type(exc).__name__}: {exc}", root)]
        return
    problems = []
    if ours.mean.shape != mit.mean.shape:
        problems.append(f"image shapes differ: ours {ours.mean.shape}, Mitsuba {mit.mean.shape}")
    for who, img in (("ours", ours), ("Mitsuba", mit)):
        if not (np.all(np.isfinite(img.mean)) and np.all(np.isfinite(img.variance))):
            problems.append(f"{who}: NaN or Inf in the mean or variance")
    if problems:
        rec["status"], rec["reasons"] = "render-error", problems
        return
    try:
        a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    except Exception as exc:  # noqa: BLE001 - e.g. a filtered render without its pixel samples
        rec["status"], rec["reasons"] = "render-error", [clean_message(f"agreement: {exc}", root)]
        return
    glob, share, fixed = list(a.global_z), a.share, a.spreadless
    rec.update(global_z=[g if math.isfinite(g) else str(g) for g in glob], share_z4=share, spreadless_differences=fixed,
               mean_ours=[float(x) for x in ours.mean.reshape(-1, 3).mean(axis=0)],
               mean_mitsuba=[float(x) for x in mit.mean.reshape(-1, 3).mean(axis=0)],
               status="agrees" if a.agrees else "disagrees")
    if rec["status"] == "disagrees":
        worst = max(range(3), key=lambda c: abs(glob[c]))
        rec["reasons"] = [f"global z {glob[worst]:+.1f} in {'RGB'[worst]}, {100 * share:.1f}% of pixel values "
                          f"with |z| > {Z_LIMIT:g}"
                          + (f", {fixed} pixel value(s) differ where neither render has spread" if fixed else "")]
