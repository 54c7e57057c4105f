"""Glass (issue 8): rays starting inside, total internal reflection, ior 1.0 = no glass."""
import pytest

from benchmarks import stress


@pytest.fixture(scope="module")
def record():
    return stress.glass(width=32, spp=32, seed=0)


def test_camera_inside_glass_sphere_sees_exactly_ior_squared(record):
    """Normal incidence everywhere: every sample is 1.5^2 = 2.25 (Mitsuba's 1/eta^2)."""
    assert record.details["expected_inside"] == 2.25
    assert record.details["centre_pixels_wrong"] == 0


def test_total_internal_reflection_traps_exactly(record):
    d = record.details
    print(record.figure)
    assert d["tir_pixels"] > 100 and d["exit_pixels"] > 100      # both regions are in view
    assert d["tir_pixels_wrong"] == 0                           # exactly 0: nothing escapes TIR
    assert d["exit_pixels_wrong"] == 0                          # exactly 2.25


@pytest.mark.parametrize("strategy", ["cosine", "mis"])
def test_ior_one_equals_no_glass(record, strategy):
    zt = record.details["ior1_vs_none"][strategy]
    assert zt["passed"], zt


def test_no_nonfinite_samples(record):
    assert record.details["nonfinite_samples"] == 0


@pytest.mark.slow
def test_glass_more_samples():
    rec = stress.glass(width=64, spp=64, compare_spp=512, compare_width=32, seed=1)
    assert rec.passed
