"""Sweep presets for ``rtbench run``: ``quick`` (the default) and ``full``.

Each preset is a list of :class:`benchmarks.sweep.Group`: the main sweep of the whole
suite, and the seed's own comparison (uniform vs light sampling on ``SEED_SCENE`` at
``SEED_SIZE`` x ``SEED_SIZE`` with ``SEED_SPP`` among the sample counts, ``reports``
issue 6; the three from :mod:`benchmarks.constants`).

``quick``
    32x32 images, spp 1, 4, 16, 64, 256 (five budgets: every slope is fitted to four or
    more), 4 seeds, our five strategies and Mitsuba, references at 8192 spp; seed
    comparison at 400x400 with spp 1, 2, 4, 16, 50 and one seed (reference 64 spp: the seed
    figure's error maps and RMSE, no verdict, rest on it). Tail references at 16384 spp
    and never more: where one's variance rests on single samples the curve says
    "undetermined" with the budget that would decide (``escalate_tails`` False). Under
    three minutes on 2 cores from an empty cache (docs/rtbench.md, Presets), seconds once cached. Sizing: on
    ``cornell_box`` at 32x32, 4 seeds at 256 spp flag the biased ``light`` strategy with
    z >= 4.7 in 8 of 8 trials (``BIAS_TEST_ALPHA`` = 0.001 needs z > 3.09).
``full``
    256x256 images, spp 1..1024, 4 seeds, references at 16384 spp; seed comparison at
    400x400, spp 1..256 plus 50, 4 seeds, references at 4096 spp; tail references grow to
    a million spp where their variance rests on single samples. Report quality; hours on a
    small machine (``--scheduler`` spreads it over a Dask cluster).

Examples
--------
>>> from benchmarks.sweep.presets import preset_groups
>>> [g.name for g in preset_groups("quick", scenes=["cornell_box"])]
['suite', 'seed comparison']
"""
from __future__ import annotations

from mitsuba_scenes import known_scenes, list_scenes

from ..constants import MITSUBA_STRATEGY, SEED_SCENE, SEED_SIZE, SEED_SPP, STRATEGIES
from .jobs import Group, mitsuba_strategies

__all__ = ["PRESETS", "SEED_SCENE", "preset_groups", "describe_preset", "escalates_tails"]

#: preset names, default first.
PRESETS = ("quick", "full")


def _ladder(top: int) -> tuple:
    out, s = [], 1
    while s <= top:
        out.append(s)
        s *= 2
    return tuple(out)


_SPECS = {
    "quick": {
        "suite": dict(strategies=STRATEGIES, spps=(1, 4, 16, 64, 256), seeds=4, width=32, height=32, mitsuba=True,
                      reference_spp=8192),
        "seed": dict(strategies=("uniform", "light"), spps=(1, 2, 4, 16, SEED_SPP), seeds=1, width=SEED_SIZE,
                     height=SEED_SIZE, mitsuba=False, reference_spp=64),
        "escalate_tails": False,
    },
    "full": {
        "suite": dict(strategies=STRATEGIES, spps=_ladder(1024), seeds=4, width=256, height=256, mitsuba=True,
                      reference_spp=16384),
        "seed": dict(strategies=("uniform", "light"), spps=tuple(sorted(set(_ladder(256)) | {SEED_SPP})),
                     seeds=4, width=SEED_SIZE, height=SEED_SIZE, mitsuba=False, reference_spp=4096),
        "escalate_tails": True,
    },
}


def escalates_tails(name: str) -> bool:
    """Whether preset ``name`` renders larger tail references where a variance rests on single samples.

    >>> escalates_tails("quick"), escalates_tails("full")
    (False, True)
    """
    if name not in _SPECS:
        raise ValueError(f"unknown preset {name!r}; choose from {', '.join(PRESETS)}")
    return bool(_SPECS[name]["escalate_tails"])


def preset_groups(name: str = "quick", *, scenes=None) -> list:
    """The sweep groups of preset ``name``.

    Parameters
    ----------
    name : {'quick', 'full'}
    scenes : sequence of str or None, keyword-only
        Restrict to these suite scenes or registered scene files (default: the whole suite). The seed comparison
        is included when ``cornell_box`` is among them.

    Returns
    -------
    list of Group

    Examples
    --------
    >>> g = preset_groups("full", scenes=["cornell_box"])[0]
    >>> g.width, max(g.spps), g.seeds
    (256, 1024, 4)
    """
    if name not in _SPECS:
        raise ValueError(f"unknown preset {name!r}; choose from {', '.join(PRESETS)}")
    suite = known_scenes()  # the suite and the registered scene files (--scene)
    if scenes is None:
        scenes = list_scenes()
    else:
        if isinstance(scenes, str):
            scenes = [s.strip() for s in scenes.split(",") if s.strip()]
        scenes = list(dict.fromkeys(scenes))
        unknown = [s for s in scenes if s not in suite]
        if unknown:
            raise ValueError(f"unknown scene(s) {unknown}; the suite has: {', '.join(suite)}")
        if not scenes:
            raise ValueError("no scene selected")
    spec = _SPECS[name]
    groups = [Group(scenes=tuple(scenes), name="suite", **spec["suite"])]
    if SEED_SCENE in scenes:
        groups.append(Group(scenes=(SEED_SCENE,), name="seed comparison", **spec["seed"]))
    return groups


def describe_preset(name: str, *, scenes=None) -> str:
    """One line per group of a preset (restricted to ``scenes`` as :func:`preset_groups`): what it renders.

    Examples
    --------
    >>> print(describe_preset("quick").splitlines()[0])  # doctest: +ELLIPSIS
    suite: ... at 32x32, spp 1..256, 4 seeds, ...
    >>> print(describe_preset("quick", scenes=["furnace"]))  # doctest: +ELLIPSIS
    suite: 1 scene(s) at 32x32, ...
    """
    lines = []
    for g in preset_groups(name, scenes=scenes):
        who = ", ".join(g.strategies)
        if g.mitsuba:
            kinds = {"path" if mitsuba_strategies(s) == (MITSUBA_STRATEGY,) else
                     "direct (BSDF, emitter and MIS samples)" for s in g.scenes}
            who += " + Mitsuba " + " / ".join(sorted(kinds, reverse=True))
        spp = f"{min(g.spps)}..{max(g.spps)}" if len(g.spps) > 3 else ",".join(map(str, g.spps))
        lines.append(f"{g.name}: {len(g.scenes)} scene(s) at {g.width}x{g.height}, spp {spp}, {g.seeds} seeds, "
                     f"{who}; reference {g.reference_spp} spp")
    return "\n".join(lines)
