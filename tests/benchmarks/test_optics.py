"""The closed forms of optics the checks compare the tracer against (``benchmarks.optics``)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.optics import fresnel_dielectric


def test_fresnel_at_normal_incidence_and_beyond_the_critical_angle():
    assert fresnel_dielectric(1.0, 1.5) == pytest.approx(0.04)                # ((1.5 - 1) / (1.5 + 1))^2
    assert fresnel_dielectric(-1.0, 1.5) == pytest.approx(0.04)               # the same from inside
    assert fresnel_dielectric(-np.cos(np.arcsin(0.7)), 1.5) == 1.0            # beyond critical: TIR
    assert fresnel_dielectric(-math.cos(math.radians(60)), 1.5) == 1.0        # total internal reflection
    assert fresnel_dielectric(math.cos(math.radians(50)), 0.7) == 1.0         # ior < 1, from outside


def test_fresnel_is_elementwise_and_nan_safe():
    cos = np.linspace(-1.0, 1.0, 101)
    whole = fresnel_dielectric(cos, 1.5)
    assert whole.shape == cos.shape
    assert np.array_equal(whole, [fresnel_dielectric(float(c), 1.5) for c in cos])
    assert np.all((whole > 0.0) & (whole <= 1.0))
    with np.errstate(all="raise"):
        out = fresnel_dielectric([np.nan, 0.5], 1.5)
    assert np.isnan(out[0]) and 0.0 < out[1] < 1.0
