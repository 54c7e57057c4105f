"""Sweep presets of ``rtbench run``: ``quick`` (the default) and ``full``, each the main sweep of
the suite plus the seed comparison (docs/rtbench.md, Presets and the main run). ``quick``'s
4 seeds at 256 spp flag the biased ``light`` on ``cornell_box`` at 32x32 with z >= 4.7 in 8
of 8 trials (``BIAS_TEST_ALPHA`` needs z > 3.09).

>>> [g.name for g in preset_groups("quick", scenes=["cornell_box"])]
['suite', 'seed comparison']
"""
from __future__ import annotations

from mitsuba_scenes import list_scenes

from ..constants import MITSUBA_STRATEGY, SEED_SCENE, SEED_SIZE, SEED_SPP, STRATEGIES
from .jobs import Group, mitsuba_strategies

#: preset names, default first.
PRESETS = ("quick", "full")


def _ladder(top: int) -> tuple:
    """1, 2, 4, ... up to ``top``."""
    return tuple(2 ** k for k in range(top.bit_length()))


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


def _spec(name: str) -> dict:
    if name not in _SPECS:
        raise ValueError(f"unknown preset {name!r}; choose from {', '.join(PRESETS)}")
    return _SPECS[name]


def escalates_tails(name: str) -> bool:
    """Whether preset ``name`` renders larger tail references where a variance rests on single samples.

    >>> escalates_tails("quick"), escalates_tails("full")
    (False, True)
    """
    return bool(_spec(name)["escalate_tails"])


def preset_groups(name: str = "quick", *, scenes=None) -> list:
    """The sweep groups (:class:`~benchmarks.sweep.Group`) of preset ``name``, restricted to
    ``scenes`` (suite scenes or registered scene files; default the suite); the seed
    comparison where ``cornell_box`` is among them.

    >>> g = preset_groups("full", scenes=["cornell_box"])[0]
    >>> g.width, max(g.spps), g.seeds
    (256, 1024, 4)
    """
    spec = _spec(name)
    scenes = list_scenes() if scenes is None else list(dict.fromkeys(scenes))  # Group checks the names
    groups = [Group(scenes=tuple(scenes), name="suite", **spec["suite"])]
    if SEED_SCENE in scenes:
        groups.append(Group(scenes=(SEED_SCENE,), name="seed comparison", **spec["seed"]))
    return groups


def describe_preset(name: str, *, scenes=None) -> str:
    """One line per group of a preset (restricted to ``scenes`` as :func:`preset_groups`): what it renders.

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
