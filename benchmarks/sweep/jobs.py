"""The job list of a sweep: :class:`Job`, :class:`Group` (validated where it is made), the
render seeds and which Mitsuba curve each of ours is compared with."""
from __future__ import annotations

import hashlib
from dataclasses import dataclass

import reference_tracer as rt
from reference_tracer.render import BLIND_TO_DELTA_LIGHTS
from reference_tracer.validation import positive_int
from mitsuba_scenes import get_scene, known_scenes

from ..constants import MITSUBA_DIRECT, MITSUBA_STRATEGY, STRATEGIES
from ..external import STRATEGY as EXTERNAL
from ..external import external, registered_externals
from ..files import slug
from ..store import KEY_FIELDS, curve_label


@dataclass(frozen=True)
class Job:
    """One render of the sweep; ``build`` (:func:`renderer_builds`) ends its store key, so a
    new build renders the job again."""

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
        return f"{curve_label(self.curve)} {self.spp} spp seed {self.seed}"

    @property
    def cost(self) -> float:
        """Rough relative cost for the progress bar's time estimate (seconds at ~1 us/sample)."""
        return self.width * self.height * self.spp * 1e-6 + (0.3 if self.renderer == "mitsuba" else 0.03)


@dataclass(frozen=True)
class Group:
    """A block of a sweep: every scene x curve x spp x seed (indices ``0 .. seeds-1``) at one size.

    ``strategies``: ours; ``mitsuba``: add Mitsuba's curve(s); ``reference_spp``: of the
    reference (well above ``max(spps)``); ``externals``: registered external renderers
    (:func:`benchmarks.external.register_external`), one curve each; ``name``: for messages.
    ``ValueError`` for a malformed group.
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
        if isinstance(self.scenes, str) or not self.scenes:
            raise ValueError(f"scenes must be a non-empty sequence of names, got {self.scenes!r}")
        unknown = [s for s in self.scenes if s not in known_scenes()]
        if unknown:
            raise ValueError(f"unknown scene(s) {unknown}; the suite has: {', '.join(known_scenes())}")
        if isinstance(self.strategies, str):
            raise ValueError(f"strategies must be a sequence of names, got {self.strategies!r}")
        bad = [s for s in self.strategies if s not in STRATEGIES]
        if bad:
            raise ValueError(f"unknown strategy/strategies {bad}; choose from {', '.join(STRATEGIES)}")
        if len(set(self.strategies)) != len(tuple(self.strategies)):
            raise ValueError(f"strategies has repeated names: {list(self.strategies)}")
        blind = [s for s in self.strategies if s in BLIND_TO_DELTA_LIGHTS]
        dark = [name for name in self.scenes if blind and get_scene(name).delta_lights]
        if dark:  # refused before any job renders: each of these renders would raise
            raise ValueError(f"strategies {blind} cannot see the point, spot or directional lights of scene(s) "
                             f"{dark} (no sampled direction meets a delta light): render them with mis or light")
        if isinstance(self.externals, str) or any(external(e) is None for e in self.externals):
            raise ValueError(f"externals must name registered external renderers, got {self.externals!r}")
        if not self.strategies and not self.mitsuba and not self.externals:
            raise ValueError("nothing to render: no strategy, no external renderer and mitsuba=False")
        if isinstance(self.spps, (str, bytes)) or not self.spps:
            raise ValueError(f"spps must be a non-empty sequence of integers, got {self.spps!r}")
        spps = [positive_int("spps", s) for s in self.spps]
        if len(set(spps)) != len(spps):
            raise ValueError(f"spps has repeated values: {spps}")
        for name in ("seeds", "width", "height"):
            positive_int(name, getattr(self, name))
        positive_int("reference_spp", self.reference_spp, minimum=2)

    def jobs(self) -> list:
        return make_jobs(self.scenes, strategies=self.strategies, spps=self.spps, seeds=self.seeds,
                         width=self.width, height=self.height, mitsuba=self.mitsuba, externals=self.externals)


def make_jobs(scenes, *, strategies, spps, seeds: int, width: int, height: int,
              mitsuba: bool = True, externals=()) -> list:
    """All jobs of a sweep, cheapest spp first (curves fill in together).

    >>> jobs = make_jobs(["cornell_box"], strategies=["mis"], spps=[1, 4], seeds=2, width=8, height=8)
    >>> len(jobs), jobs[0].label
    (8, 'cornell_box 8x8 mis 1 spp seed 0')
    """
    ours = [("ours", s) for s in strategies]
    others = [(e, EXTERNAL) for e in externals]
    per_scene = {scene: ours + ([("mitsuba", s) for s in mitsuba_strategies(scene)] if mitsuba else []) + others
                 for scene in scenes}
    return [Job(scene, renderer, strategy, int(spp), seed, int(width), int(height))
            for scene in scenes for spp in sorted(spps) for seed in range(int(seeds))
            for renderer, strategy in per_scene[scene]]


def mitsuba_strategies(scene: str) -> tuple:
    """Mitsuba's curves of ``scene``: ``path``, or for a scene with Mitsuba's ``direct``
    integrator the three of Veach's comparison (:data:`MITSUBA_DIRECT`).

    >>> mitsuba_strategies("cornell_box")
    ('path',)
    """
    return tuple(MITSUBA_DIRECT) if get_scene(scene).direct is not None else (MITSUBA_STRATEGY,)


def mitsuba_twin(strategy: str, available) -> str | None:
    """The Mitsuba curve among ``available`` our ``strategy`` is compared with: ``path``, or
    under ``direct`` the one with the same counts, else ``direct_mis``.

    >>> mitsuba_twin("light", ["direct_bsdf", "direct_light", "direct_mis"])
    'direct_light'
    """
    available = list(available)
    if MITSUBA_STRATEGY in available:
        return MITSUBA_STRATEGY
    twin = {ours: name for name, ours in MITSUBA_DIRECT.items()}.get(strategy, "direct_mis")
    return twin if twin in available else ("direct_mis" if "direct_mis" in available else None)


def mitsuba_pairs(rows):
    """``(row, Mitsuba's row it is compared with or None)`` for every summary row (a Mitsuba row: itself)."""
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
    """``{renderer: build}`` of this process: ours ``reference_tracer.build_id()``, Mitsuba's
    version and variant, each external renderer's.

    >>> renderer_builds("scalar_rgb", "3.9.1")["mitsuba"]
    'mitsuba-3.9.1-scalar_rgb'
    """
    return {"ours": rt.build_id(), "mitsuba": f"mitsuba-{mitsuba_version}-{variant}",
            **{e.name: e.build for e in registered_externals()}}


def render_seed(seed: int, spp: int) -> int:
    """The renderer's seed for seed index ``seed`` at ``spp``: a 62-bit hash of both, so that
    renders at different spp are independent (the slope's interval assumes it).

    >>> render_seed(0, 4) != render_seed(0, 8) != render_seed(1, 4)
    True
    """
    h = hashlib.sha256(f"rtbench-sweep:{int(seed)}:{int(spp)}".encode()).digest()
    return int.from_bytes(h[:8], "little") >> 2


def image_paths(job: Job) -> tuple:
    """Store-relative paths of a job's mean and variance EXR images.

    >>> image_paths(Job("furnace", "ours", "mis", 4, 1, 8, 6))[0]
    'images/furnace_8x6/ours_mis_spp4_seed1.exr'
    """
    stem = (f"images/{slug(job.scene, f'{job.width}x{job.height}')}/"
            f"{slug(job.renderer, job.strategy, f'spp{job.spp}', f'seed{job.seed}')}")
    return f"{stem}.exr", f"{stem}_var.exr"
