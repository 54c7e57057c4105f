"""The job list of a sweep: :class:`Job`, :class:`Group`, their validation and the render seeds.

A *job* is one render: (scene, renderer, strategy, spp, seed, width, height), the store
key of its record (``benchmarks/STORE.md``). A :class:`Group` is a block of jobs: every
scene x curve x spp x seed at one image size.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

import reference_tracer as rt
from reference_tracer.render import BLIND_TO_DELTA_LIGHTS
from mitsuba_scenes import get_scene, known_scenes

from ..constants import MITSUBA_DIRECT, MITSUBA_STRATEGY, STRATEGIES
from ..external import STRATEGY as EXTERNAL
from ..external import external, registered_externals
from ..files import slug
from ..store import KEY_FIELDS

__all__ = ["Job", "Group", "validate_group", "make_jobs", "mitsuba_strategies", "mitsuba_twin", "mitsuba_pairs", "renderer_builds", "render_seed",
           "image_paths", "check_int", "check_int_list"]


@dataclass(frozen=True)
class Job:
    """One render of the sweep (its identity is the store key, ``STORE.md``).

    ``build`` is the renderer's build (:func:`renderer_builds`): part of the key, so a
    new build renders the job again.
    """

    scene: str
    renderer: str
    strategy: str
    spp: int
    seed: int
    width: int
    height: int
    build: str | None = None

    @property
    def key(self) -> tuple:
        return tuple(getattr(self, k) for k in KEY_FIELDS) + (self.build,)

    @property
    def curve(self) -> tuple:
        return (self.scene, self.renderer, self.strategy, self.width, self.height)

    @property
    def label(self) -> str:
        who = self.strategy if self.renderer == "ours" else f"{self.renderer} {self.strategy}"
        return f"{self.scene} {self.width}x{self.height} {who} {self.spp} spp seed {self.seed}"

    @property
    def cost(self) -> float:
        """Rough relative cost for the progress bar's time estimate (seconds at ~1 us/sample)."""
        samples = self.width * self.height * self.spp
        return samples * 1e-6 + (0.3 if self.renderer == "mitsuba" else 0.03)


@dataclass(frozen=True)
class Group:
    """A block of a sweep: every scene x curve x spp x seed at one image size.

    Parameters
    ----------
    scenes : tuple of str
        Suite scene names.
    strategies : tuple of str
        Our strategies (``reference_tracer.STRATEGIES``).
    spps : tuple of int
        The spp ladder.
    seeds : int
        Number of independent seeds per (curve, spp); seed indices are ``0 .. seeds-1``.
    width, height : int
    mitsuba : bool
        Add Mitsuba's ``path`` curve.
    reference_spp : int
        Samples of the Mitsuba reference (keep it well above ``max(spps)``).
    name : str
        A label for messages.
    externals : tuple of str
        Names of registered external renderers (:func:`benchmarks.external.register_external`),
        one curve each.
    """

    scenes: tuple
    strategies: tuple
    spps: tuple
    seeds: int
    width: int
    height: int
    mitsuba: bool = True
    reference_spp: int = 4096
    name: str = "curves"
    externals: tuple = ()

    def __post_init__(self):
        validate_group(self)

    def jobs(self) -> list:
        return make_jobs(self.scenes, strategies=self.strategies, spps=self.spps, seeds=self.seeds,
                         width=self.width, height=self.height, mitsuba=self.mitsuba, externals=self.externals)


def check_int(name: str, value, minimum: int = 1) -> int:
    """``value`` as an int, or ``ValueError`` naming ``name`` unless it is an integer >= ``minimum``.

    Examples
    --------
    >>> check_int("seeds", 3)
    3
    >>> check_int("seeds", True)
    Traceback (most recent call last):
    ...
    ValueError: seeds must be an integer >= 1, got True
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def check_int_list(name: str, values, minimum: int = 1) -> tuple:
    """``values`` as a tuple of distinct ints >= ``minimum``, or ``ValueError`` naming ``name``.

    Examples
    --------
    >>> check_int_list("spps", [4, 1])
    (4, 1)
    >>> check_int_list("spps", [4, 4])
    Traceback (most recent call last):
    ...
    ValueError: spps has repeated values: [4, 4]
    """
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ValueError(f"{name} must be a sequence of integers, got {values!r}")
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < minimum:
            raise ValueError(f"{name} must hold integers >= {minimum}, got {v!r}")
        out.append(int(v))
    if not out:
        raise ValueError(f"{name} is empty")
    if len(set(out)) != len(out):
        raise ValueError(f"{name} has repeated values: {out}")
    return tuple(out)


def validate_group(g: Group) -> None:
    """Raise ``ValueError`` with a clear message for a malformed :class:`Group`."""
    suite = known_scenes()
    if isinstance(g.scenes, str) or not g.scenes:
        raise ValueError(f"scenes must be a non-empty sequence of names, got {g.scenes!r}")
    unknown = [s for s in g.scenes if s not in suite]
    if unknown:
        raise ValueError(f"unknown scene(s) {unknown}; the suite has: {', '.join(suite)}")
    if isinstance(g.strategies, str):
        raise ValueError(f"strategies must be a sequence of names, got {g.strategies!r}")
    bad = [s for s in g.strategies if s not in STRATEGIES]
    if bad:
        raise ValueError(f"unknown strategy/strategies {bad}; choose from {', '.join(STRATEGIES)}")
    if len(set(g.strategies)) != len(tuple(g.strategies)):
        raise ValueError(f"strategies has repeated names: {list(g.strategies)}")
    blind = [s for s in g.strategies if s in BLIND_TO_DELTA_LIGHTS]
    if blind:
        # refused before any job renders: each of these renders would raise the same error
        dark = [name for name in g.scenes if get_scene(name).delta_lights]
        if dark:
            raise ValueError(f"strategies {blind} cannot see the point, spot or directional lights of scene(s) "
                             f"{dark} (no sampled direction meets a delta light): render them with mis or light")
    if isinstance(g.externals, str) or any(external(e) is None for e in g.externals):
        raise ValueError(f"externals must name registered external renderers, got {g.externals!r}")
    if not g.strategies and not g.mitsuba and not g.externals:
        raise ValueError("nothing to render: no strategy, no external renderer and mitsuba=False")
    check_int_list("spps", g.spps)
    for name in ("seeds", "width", "height"):
        check_int(name, getattr(g, name))
    check_int("reference_spp", g.reference_spp, 2)


def make_jobs(scenes, *, strategies, spps, seeds: int, width: int, height: int,
              mitsuba: bool = True, externals=()) -> list:
    """All jobs of a sweep, cheapest spp first (curves fill in together).

    Examples
    --------
    >>> jobs = make_jobs(["cornell_box"], strategies=["mis"], spps=[1, 4], seeds=2, width=8, height=8)
    >>> len(jobs), jobs[0].label
    (8, 'cornell_box 8x8 mis 1 spp seed 0')
    """
    spps = check_int_list("spps", spps)

    ours = [("ours", s) for s in strategies]
    others = [(e, EXTERNAL) for e in externals]
    per_scene = {scene: ours + ([("mitsuba", s) for s in mitsuba_strategies(scene)] if mitsuba else []) + others
                 for scene in scenes}
    return [Job(scene, renderer, strategy, spp, seed, int(width), int(height))
            for scene in scenes for spp in sorted(spps) for seed in range(int(seeds))
            for renderer, strategy in per_scene[scene]]


def mitsuba_strategies(scene: str) -> tuple:
    """Mitsuba's curves of suite scene or scene file ``scene``: its ``path`` integrator, or for a
    scene with Mitsuba's ``direct`` integrator the three of Veach's comparison (:data:`MITSUBA_DIRECT`).

    Examples
    --------
    >>> mitsuba_strategies("cornell_box")
    ('path',)
    """
    return tuple(MITSUBA_DIRECT) if get_scene(scene).direct is not None else (MITSUBA_STRATEGY,)


def mitsuba_twin(strategy: str, available) -> str | None:
    """The Mitsuba curve among ``available`` that our ``strategy`` is compared with: ``path``
    where Mitsuba renders the path integrator; under ``direct`` the one with the same counts
    (``cosine`` - ``direct_bsdf``, ``light`` - ``direct_light``), else ``direct_mis``.

    Examples
    --------
    >>> mitsuba_twin("light", ["direct_bsdf", "direct_light", "direct_mis"])
    'direct_light'
    >>> mitsuba_twin("uniform", ["path"])
    'path'
    """
    available = list(available)
    if MITSUBA_STRATEGY in available:
        return MITSUBA_STRATEGY
    twin = {ours: name for name, ours in MITSUBA_DIRECT.items()}.get(strategy, "direct_mis")
    return twin if twin in available else ("direct_mis" if "direct_mis" in available else None)


def mitsuba_pairs(rows):
    """``(row, Mitsuba's row it is compared with or None)`` for every summary row: the
    :func:`mitsuba_twin` curve of the same scene and size (a Mitsuba row: itself)."""
    mits = {}
    for r in rows:
        if r["renderer"] == "mitsuba":
            mits.setdefault((r["scene"], r["width"], r["height"]), {})[r["strategy"]] = r
    for r in rows:
        if r["renderer"] == "mitsuba":
            yield r, r
            continue
        same = mits.get((r["scene"], r["width"], r["height"]), {})
        twin = mitsuba_twin(r["strategy"], same)
        yield r, same.get(twin) if twin else None


def renderer_builds(variant: str | None, mitsuba_version: str | None) -> dict:
    """``{renderer: build}`` of this process: ours is ``reference_tracer.build_id()``, Mitsuba's
    its version and variant.

    Examples
    --------
    >>> renderer_builds("scalar_rgb", "3.9.1")["mitsuba"]
    'mitsuba-3.9.1-scalar_rgb'
    """
    return {"ours": rt.build_id(), "mitsuba": f"mitsuba-{mitsuba_version}-{variant}",
            **{e.name: e.build for e in registered_externals()}}


def render_seed(seed: int, spp: int) -> int:
    """The seed given to the renderer for seed index ``seed`` at ``spp``: a 62-bit hash.

    Examples
    --------
    >>> render_seed(0, 4) != render_seed(0, 8) != render_seed(1, 4)
    True
    """
    h = hashlib.sha256(f"rtbench-sweep:{int(seed)}:{int(spp)}".encode()).digest()
    return int.from_bytes(h[:8], "little") >> 2


def image_paths(job: Job) -> tuple:
    """Store-relative paths of a job's mean and variance EXR images.

    Examples
    --------
    >>> image_paths(Job("furnace", "ours", "mis", 4, 1, 8, 6))[0]
    'images/furnace_8x6/ours_mis_spp4_seed1.exr'
    """
    stem = (f"images/{slug(job.scene, f'{job.width}x{job.height}')}/"
            f"{slug(job.renderer, job.strategy, f'spp{job.spp}', f'seed{job.seed}')}")
    return f"{stem}.exr", f"{stem}_var.exr"
