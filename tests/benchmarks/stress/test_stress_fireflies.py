"""Fireflies on small_light (issue 8): samples above 100x the image mean, per strategy.

Per-sample values come from 128 one-sample renders with distinct seeds (the mean of a
1-spp render is its sample). ``mis`` must have at least two orders of magnitude fewer
than ``uniform``.
"""
import pytest

import reference_tracer as rt
from benchmarks import stress
from mitsuba_scenes import get_scene


def test_mis_has_orders_fewer_fireflies_than_uniform():
    fc = stress.firefly_counts(get_scene("small_light", width=64, height=64), strategies=("uniform", "mis"),
                               renders=128, factor=100.0, seed=0)
    print(fc["counts"], fc["threshold"])
    assert fc["samples"]["uniform"] > 500_000
    assert fc["counts"]["uniform"] >= 100 * max(fc["counts"]["mis"], 1)
    assert fc["nonfinite_samples"] == 0


@pytest.mark.parametrize("strategies, renders, message", [(("uniform", "cosine"), 2, "needs 'mis'"),
                                                          (("mis",), 0, "renders must be at least 1")])
def test_firefly_counts_refuses_what_it_cannot_measure(strategies, renders, message):
    """The threshold is a multiple of mis's mean: without mis (or renders) a clear error, not a KeyError."""
    with pytest.raises(ValueError, match=message):
        stress.firefly_counts(get_scene("small_light", width=8, height=8), strategies=strategies, renders=renders)


@pytest.mark.slow
def test_fireflies_every_strategy():
    rec = stress.fireflies(width=64, renders=512, seed=1)
    print(rec.figure)
    c = rec.details["counts"]
    assert set(c) == set(rt.STRATEGIES)
    assert rec.passed
    assert c["cosine"] >= 10 * max(c["mis"], 1)     # BSDF sampling alone also fireflies on a small light
