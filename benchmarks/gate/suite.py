"""The gate's suite driver (``rtbench gate``): our tracer against the references.

:func:`run_gate` renders each suite scene and strategy with our tracer, fetches its reference
(:func:`gate_reference`: the closed form of ``furnace``, where Mitsuba 3.9.1 is biased, else the
cached high-spp Mitsuba render) and applies :func:`benchmarks.gate.compare` at ``alpha / k`` for
``k`` comparisons, so the whole run holds ``alpha``; :func:`write_p_images` draws the p-value
images of failures.

The defaults (CI-sized): the quick suite at 32 x 32, ``mis`` at 4096 spp against 16384-spp
references and tail references, roulette from depth 5. Power chose the spp (seeds 1-6, ``power_row``): a
1% light move along x is caught 1/6 at 1024 spp and 6/6 at 4096; a 1% global scale 6/6 at 1024.

Examples
--------
>>> from benchmarks.gate import run_gate
>>> report = run_gate(["cornell_box"], spp=64, threads=2)  # doctest: +SKIP
>>> report.passed, report.cases[0].result.p_value  # doctest: +SKIP
(True, 0.83)
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import known_scenes, list_scenes
from reference_tracer.validation import SEED_MAX, positive_int

from ..constants import GATE_ALPHA, STRATEGIES
from ..display import pyplot
from ..external import render_external_batches
from ..files import slug
from ..references import Reference, closed_form_reference_of
from ..references import reference as mitsuba_reference
from ..scenes import scene_at
from ..stats import sidak
from ..tails import DEFAULT_TAIL_SPP, tail_reference
from .filtered import filter_weights
from .statistics import LEVELS, GateResult, compare
from .store_reference import store_reference

__all__ = ["gate_tails", "DEFAULT_SPP", "DEFAULT_WIDTH", "DEFAULT_REF_SPP", "DEFAULT_SEED", "DEFAULT_STRATEGY",
           "GateCase", "GateReport", "gate_scene", "names_of", "resolve_scenes", "resolve_strategies", "gate_reference",
           "compare_render", "run_gate", "write_p_images"]

#: samples per pixel of our render (see the power table in ``tests/benchmarks/gate/test_gate_power.py``).
DEFAULT_SPP = 4096
#: image width (and height) of the quick suite.
DEFAULT_WIDTH = 32
#: samples per pixel of the Mitsuba references (4x ``DEFAULT_SPP``).
DEFAULT_REF_SPP = 16384
#: seed of our render (Mitsuba references use ``benchmarks.references.DEFAULT_REFERENCE_SEED``).
DEFAULT_SEED = 0
#: the strategy always gated: Mitsuba's ``path`` integrator is MIS.
DEFAULT_STRATEGY = "mis"


@dataclass
class GateCase:
    """One (scene, strategy) comparison of a gate run at level ``alpha`` (the run's over the
    number of comparisons): its ``reference``, ``result`` and our render (``mean``, ``variance``)."""

    scene: str
    strategy: str
    width: int
    height: int
    spp: int
    seed: int
    alpha: float
    reference: Reference
    result: GateResult
    render_seconds: float
    mean: np.ndarray = field(repr=False)
    variance: np.ndarray = field(repr=False)
    tail_spp: int = 0

    @property
    def passed(self) -> bool:
        return bool(self.result.passed)

    @property
    def failed(self) -> bool:
        return bool(self.result.failed)

    @property
    def verdict(self) -> str:
        return self.result.verdict

    def where(self) -> str:
        """Where the strongest evidence is, e.g. ``'rows 0-7, cols 8-15 (tile)'``."""
        r = self.result
        if r.worst_level == "image":
            return "whole image"
        r0, c0, r1, c1 = r.worst_region
        if r.worst_level == "pixel":
            ch = "RGB"[r.worst_pixel[2]] if r.pixel_p.shape[2] == 3 else str(r.worst_pixel[2])
            return f"pixel row {r0}, col {c0} ({ch})"
        return f"rows {r0}-{r1 - 1}, cols {c0}-{c1 - 1} ({r1 - r0}x{c1 - c0} tile)"

    def message(self) -> str:
        """The failure message: which scene, where, how large the bias is."""
        r = self.result
        y0, x0, y1, x1 = r.worst_tile
        msg = (f"{self.scene} ({self.strategy}, {self.width}x{self.height}, {self.spp} spp) differs from its "
               f"{self.reference.source} reference: p = {r.p_value:.3g} < {self.alpha:.3g} "
               f"(failed levels: {', '.join(r.failed_levels) or 'none'}); "
               f"relative bias of the image {r.relative_bias:+.2%} +- {r.relative_bias_se:.2%}; "
               f"strongest evidence: {self.where()}")
        if r.worst_level == "pixel":
            yy, xx, cc = r.worst_pixel
            ours, ref = float(self.mean[yy, xx, cc]), float(self.reference.mean[yy, xx, cc])
            msg += f" (ours {ours:.4g} vs reference {ref:.4g})"
        msg += f"; worst tile rows {y0}-{y1 - 1}, cols {x0}-{x1 - 1} off by {r.worst_tile_relative_bias:+.2%}"
        if r.n_nonfinite:
            msg += f"; {r.n_nonfinite} NaN/Inf pixel-channels"
        return msg

    def to_dict(self) -> dict:
        return {"scene": self.scene, "strategy": self.strategy, "width": self.width, "height": self.height,
                "spp": self.spp, "seed": self.seed, "alpha": self.alpha, "reference": self.reference.source,
                "reference_spp": self.reference.spp, "render_seconds": self.render_seconds,
                "tail_spp": self.tail_spp, **self.result.to_dict()}


@dataclass
class GateReport:
    """All comparisons of one :func:`run_gate` call: the run's ``alpha``, each comparison's
    ``case_alpha``, and the wall time spent on references, tail references and our renders."""

    cases: list
    alpha: float
    case_alpha: float
    reference_seconds: float
    render_seconds: float
    seconds: float

    tail_seconds: float = 0.0

    @property
    def passed(self) -> bool:
        """No comparison failed (undetermined ones do not fail a run; they are reported)."""
        return not self.failures

    @property
    def failures(self) -> list:
        return [c for c in self.cases if c.failed]

    @property
    def undetermined(self) -> list:
        return [c for c in self.cases if c.verdict == "undetermined"]


def gate_scene(name: str, *, width: int = DEFAULT_WIDTH, height: int | None = None):
    """Suite scene ``name`` at ``width`` x ``height`` (default square), as the quick preset builds it.

    Examples
    --------
    >>> gate_scene("cornell_box", width=16).camera.height
    16
    """
    width = positive_int("width", width)
    height = width if height is None else positive_int("height", height)
    return scene_at(name, width, height)


def gate_reference(name: str, scene, *, ref_spp: int = DEFAULT_REF_SPP, threads=None, cache=None,
                   log=None, variant: str | None = None) -> Reference:
    """The reference of suite scene ``name``: its closed form
    (:func:`benchmarks.references.closed_form_reference_of`), or the cached Mitsuba render at
    ``ref_spp`` (:func:`benchmarks.references.reference`, rendered when missing).

    Examples
    --------
    >>> ref = gate_reference("furnace", gate_scene("furnace", width=4))
    >>> ref.source, float(ref.variance.max()), ref.description[:11]
    ('closed form', 0.0, 'closed form')
    """
    exact = closed_form_reference_of(name, scene.camera.width, scene.camera.height)
    if exact is not None:
        return exact
    return mitsuba_reference(scene, spp=ref_spp, threads=threads, cache=cache, log=log, variant=variant)


def gate_tails(scene, strategy: str, *, tail_spp: int, threads, cache, log):
    """The tail reference of ``strategy`` on ``scene`` (:func:`benchmarks.tails.tail_reference`), or
    None for ``tail_spp`` 0."""
    if not tail_spp:
        return None
    return tail_reference(scene, strategy=strategy, spp=tail_spp, threads=threads, cache=cache, log=log)


def compare_render(mean, variance, spp: int, reference: Reference, *, alpha: float = GATE_ALPHA,
                   tails=None, pixel_samples=None, pixel_filter=None) -> GateResult:
    """:func:`benchmarks.gate.compare` of a render with a :class:`benchmarks.references.Reference`
    and the ``tails`` of the same estimator; a render with a tent or Gaussian ``pixel_filter``
    passes its ``pixel_samples``."""
    filtered = pixel_filter is not None and not pixel_filter.is_box
    if filtered and pixel_samples is None:
        raise ValueError("a filtered render needs its pixel_samples for the gate's statistics")
    return compare(mean, variance, spp, reference.mean, reference.variance, reference.spp, alpha=alpha,
                   tails=None if tails is None else tails.moments,
                   pixel_samples=(pixel_samples.mean, pixel_samples.variance) if filtered else None,
                   filter_weights=filter_weights(pixel_filter) if filtered else None)


def names_of(value) -> list:
    """The names in ``value``, de-duplicated in order (a string may be comma-separated)."""
    parts = value.split(",") if isinstance(value, str) else value
    return list(dict.fromkeys(n.strip() for n in parts if n.strip()))


def resolve_scenes(scenes) -> list:
    """Validated scene names (None: the whole suite; a string may be comma-separated)."""
    suite = known_scenes()
    if scenes is None:
        return list_scenes()
    scenes = names_of(scenes)
    if not scenes:
        raise ValueError("no scene selected")
    unknown = [s for s in scenes if s not in suite]
    if unknown:
        raise ValueError(f"unknown scene(s) {', '.join(unknown)}; the suite has: {', '.join(suite)}")
    return scenes


def resolve_strategies(strategies) -> list:
    """``mis`` followed by the other validated, de-duplicated strategies."""
    strategies = names_of([DEFAULT_STRATEGY, *names_of(strategies)])
    unknown = [s for s in strategies if s not in STRATEGIES]
    if unknown:
        raise ValueError(f"unknown strateg{'y' if len(unknown) == 1 else 'ies'} {', '.join(unknown)}; "
                         f"choose from {', '.join(STRATEGIES)}")
    return strategies


def run_gate(scenes=None, *, strategies=(), spp: int = DEFAULT_SPP, width: int = DEFAULT_WIDTH,
             height: int | None = None, ref_spp: int = DEFAULT_REF_SPP, alpha: float = GATE_ALPHA,
             seed: int = DEFAULT_SEED, threads: int | None = None, cache=None, log=None, on_start=None,
             on_reference=None, on_case=None, tail_spp: int = DEFAULT_TAIL_SPP, reference_store=None,
             reference_build: str | None = None, renderer=None, variant: str | None = None) -> GateReport:
    """Render each scene with our tracer and compare it with its reference.

    Parameters
    ----------
    scenes : sequence of str or None
        Suite scenes (default: the whole quick suite).
    strategies : sequence of str, keyword-only
        Strategies gated besides ``mis``, which is always included.
    spp, width, height, ref_spp, seed : int, keyword-only
        Our renders' samples per pixel (>= 2), image size (height defaults to width), the
        Mitsuba references' samples per pixel and our renders' seed.
    alpha : float, keyword-only
        False-alarm rate of the whole run.
    threads, cache, log : keyword-only
        Threads of both renderers (None: all cores), the reference cache root, and a callable
        taking a line of text.
    on_start, on_reference, on_case : callable, keyword-only
        ``on_start(scenes, strategies)`` once, with the resolved lists, after the inputs are
        checked and before any render; ``on_reference(name, phase, reference)`` with phase
        ``'start'`` (reference None) and ``'done'``; ``on_case(case)`` with each
        :class:`GateCase` as it completes.
    tail_spp : int, keyword-only
        Samples per pixel of the tail references (:func:`benchmarks.tails.tail_reference`); 0
        compares without them (which cries wolf on heavy-tailed strategies).
    reference_store, reference_build : keyword-only
        A results store of our own tracer whose images (of ``reference_build``, default the
        latest) are the references instead of Mitsuba's (:mod:`benchmarks.gate.store_reference`).
    renderer : benchmarks.external.ExternalRenderer or None, keyword-only
        Gate this external renderer instead of ours (16 batches for the variance, no tails).
    variant : str or None, keyword-only
        Mitsuba variant of the references (None: the fastest that works).

    Returns
    -------
    GateReport
    """
    names = resolve_scenes(scenes)
    strategies = resolve_strategies(strategies) if renderer is None else [renderer.name]
    spp = positive_int("spp", spp, minimum=2)
    width = positive_int("width", width)
    height = width if height is None else positive_int("height", height)
    ref_spp = positive_int("ref_spp", ref_spp, minimum=2)
    seed = positive_int("seed", seed, minimum=0, maximum=SEED_MAX)
    tail_spp = positive_int("tail_spp", tail_spp, minimum=0)
    if tail_spp == 1:
        raise ValueError("tail_spp must be 0 (no tail references) or >= 2")
    if threads is not None:
        threads = positive_int("threads", threads)
    if not (isinstance(alpha, (int, float)) and 0 < alpha < 1):
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    case_alpha = alpha / (len(names) * len(strategies))
    if on_start:
        on_start(names, strategies)

    t_start = time.perf_counter()
    scenes_built = {name: scene_at(name, width, height) for name in names}
    refs, ref_seconds = {}, 0.0
    for name in names:
        if on_reference:
            on_reference(name, "start", None)
        t0 = time.perf_counter()
        if reference_store is not None:
            refs[name] = store_reference(reference_store, name, scenes_built[name], build=reference_build)
        else:
            refs[name] = gate_reference(name, scenes_built[name], ref_spp=ref_spp, threads=threads, cache=cache,
                                        log=log, variant=variant)
        ref_seconds += time.perf_counter() - t0
        if on_reference:
            on_reference(name, "done", refs[name])
    cases, render_seconds, tail_seconds = [], 0.0, 0.0
    for name in names:
        for strategy in strategies:
            if renderer is not None:
                mean, variance, took = render_external_batches(renderer, scenes_built[name], spp=spp, seed=seed)
                out = rt.ImageEstimate(mean=mean, variance=variance, spp=spp, seconds=took, source=renderer.name)
                tails = None
            else:
                t0 = time.perf_counter()
                tails = gate_tails(scenes_built[name], strategy, tail_spp=tail_spp, threads=threads, cache=cache,
                                   log=log)
                tail_seconds += time.perf_counter() - t0
                t0 = time.perf_counter()
                out = rt.render(scenes_built[name], spp=spp, strategy=strategy, seed=seed, threads=threads)
                took = time.perf_counter() - t0
            render_seconds += took
            result = compare_render(out.mean, out.variance, spp, refs[name], alpha=case_alpha, tails=tails,
                                    pixel_samples=getattr(out, "pixel_samples", None),
                                    pixel_filter=scenes_built[name].camera.filter if renderer is None else None)
            case = GateCase(scene=name, strategy=strategy, width=width, height=height, spp=spp, seed=seed,
                            alpha=case_alpha, reference=refs[name], result=result, render_seconds=took,
                            mean=out.mean, variance=out.variance, tail_spp=tail_spp)
            cases.append(case)
            if on_case:
                on_case(case)
    return GateReport(cases=cases, alpha=float(alpha), case_alpha=case_alpha, reference_seconds=ref_seconds,
                      render_seconds=render_seconds, seconds=time.perf_counter() - t_start,
                      tail_seconds=tail_seconds)


def write_p_images(case: GateCase, out) -> list:
    """Write the p-value images of a comparison into folder ``out``; returns the paths.

    ``<scene>_<strategy>_p.exr``: per-pixel raw ``-log10 p`` (minimum over channels; 300 for
    p = 0); ``..._p.png``: the same in false colour, the pixel level's failing threshold mid-bar
    and the worst tile boxed; ``..._ours.png`` and ``..._reference.png`` beside it.
    """
    plt = pyplot()
    from matplotlib.patches import Rectangle  # deferred: matplotlib only when plotting (0.5-1.5 s)

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    stem = out / slug(case.scene, case.strategy)
    r = case.result
    with np.errstate(divide="ignore"):
        logp = -np.log10(np.asarray(r.p_map, dtype=np.float64))
    logp = np.where(np.isfinite(logp), logp, 300.0)
    paths = [Path(f"{stem}_p.exr"), Path(f"{stem}_p.png"), Path(f"{stem}_ours.png"), Path(f"{stem}_reference.png")]
    rt.write_exr(paths[0], logp.astype(np.float32))

    # the raw per-pixel p at which the pixel level alone reaches the comparison's alpha:
    # Bonferroni over the levels and Sidak over the pixel tests
    m = max(int(r.n_tests.get("pixel", 1)), 1)
    p_pix = sidak(case.alpha / len(LEVELS), m)
    thresh = -math.log10(p_pix)
    vmax = max(2.0 * thresh, float(np.nanmax(logp[logp < 300])) if np.any(logp < 300) else 0.0)
    h, w = logp.shape
    fig, ax = plt.subplots(figsize=(5.2, 4.4 * h / max(w, 1) + 0.6), dpi=100)
    im = ax.imshow(np.minimum(logp, vmax), cmap="inferno", vmin=0.0, vmax=vmax, interpolation="nearest")
    y0, x0, y1, x1 = r.worst_tile
    ax.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), x1 - x0, y1 - y0, fill=False, edgecolor="cyan", lw=1.5))
    cb = fig.colorbar(im, ax=ax)
    cb.set_label("-log10 p per pixel (min over RGB)")
    cb.ax.axhline(thresh, color="cyan", lw=1.0)
    ax.set_title(f"{case.scene} / {case.strategy}: gate p = {r.p_value:.2g}\n"
                 f"bias {r.relative_bias:+.2%}, worst tile {r.worst_tile_relative_bias:+.2%} (box)", fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])
    fig.tight_layout()
    fig.savefig(paths[1])
    plt.close(fig)
    # exposure so the reference's 99th percentile maps to about 1
    q = float(np.percentile(case.reference.mean, 99))
    exposure = -math.log2(q) if q > 0 else 0.0
    rt.write_png(paths[2], case.mean, exposure=exposure)
    rt.write_png(paths[3], case.reference.mean.astype(np.float32), exposure=exposure)
    return paths
