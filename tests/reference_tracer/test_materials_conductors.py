"""Conductors as Mitsuba models them: Beckmann and GGX, Fresnel 1 or a complex index eta + i k,
Mitsuba's named materials. (Agreement with Mitsuba's renders: test_mitsuba_agreement's
test_material; sampling against its pdf: test_chi2's catalogue.)"""
from __future__ import annotations

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.chi2.probes import BsdfProbe, direction
from reference_tracer.conductors import CONDUCTORS, conductor_ior


def test_named_materials_are_mitsubas_values():
    """The table is what Mitsuba's RGB variants use (read back from Mitsuba itself)."""
    import mitsuba as mi

    from mitsuba_scenes.variants import import_mitsuba

    import_mitsuba()
    for name in ("Au", "Cu", "Al", "Ag", "Cr", "a-C", "none"):
        p = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        eta, k = CONDUCTORS[name]
        assert np.allclose(np.ravel(p["eta.value"])[:3], eta, rtol=1e-6, atol=1e-9), name
        assert np.allclose(np.ravel(p["k.value"])[:3], k, rtol=1e-6, atol=1e-9), name


def test_conductor_options_are_validated():
    with pytest.raises(ValueError, match="unknown conductor material 'V'"):
        rt.RoughConductor(1.0, alpha=0.1, material="V")  # Mitsuba names it V_palik
    with pytest.raises(ValueError, match="not both"):
        rt.Metal(1.0, material="Au", eta=1.0)
    with pytest.raises(ValueError, match="k needs eta"):
        rt.Metal(1.0, k=2.0)
    with pytest.raises(ValueError, match="fuzzy metal"):
        rt.Metal(1.0, fuzz=0.2, material="Au")
    with pytest.raises(ValueError, match="distribution"):
        rt.RoughConductor(1.0, alpha=0.1, distribution="phong")
    m = rt.Metal(1.0, eta=1.5)
    assert m.k == (1.0, 1.0, 1.0)  # Mitsuba's default k with an eta
    assert rt.Metal(1.0, material="none").eta is None  # Fresnel 1
    assert conductor_ior("Au") == (rt.Metal(1.0, material="Au").eta, rt.Metal(1.0, material="Au").k)


def test_translation_gives_mitsuba_the_same_index():
    from mitsuba_scenes.translate.bsdfs import bsdf_record

    rec = bsdf_record("x", rt.RoughConductor((0.9, 0.9, 0.9), alpha=0.2, distribution="beckmann", material="Cu"))
    eta, k = conductor_ior("Cu")
    assert rec["distribution"] == "beckmann" and "material" not in rec
    assert np.allclose(rec["eta"]["value"], eta, rtol=1e-6) and np.allclose(rec["k"]["value"], k, rtol=1e-6)
    assert bsdf_record("x", rt.RoughConductor(1.0, alpha=0.2))["material"] == "none"


@pytest.mark.parametrize("alpha", [0.1, 0.5, 1.0])
@pytest.mark.parametrize("theta", [0, 60, 85])
def test_beckmann_conserves_energy(alpha, theta):
    """A white conductor with Fresnel 1 reflects at most what arrives: the mean sample weight
    (f cos / pdf) is at most 1, within 4 standard errors (a one-sided false-alarm rate of
    3e-5 per case under the normal approximation of a mean of 2e5 bounded weights)."""
    probe = BsdfProbe("rough_conductor_beckmann", direction(theta, 40.0), param=alpha, albedo=(1.0, 1.0, 1.0))
    u = np.random.default_rng(7).random((200_000, 3))
    s = probe.sample_full(u)
    w = np.where(s["valid"].astype(bool), s["weight"][:, 0], 0.0)
    assert np.all(w >= 0)
    assert w.mean() <= 1.0 + 4.0 * w.std() / np.sqrt(w.size)


def test_fresnel_of_a_named_conductor_at_normal_incidence():
    """A smooth gold mirror seen head-on reflects ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2) of
    each channel, the closed form at normal incidence: a camera looking straight at it and the
    sky behind the camera of radiance 1."""
    eta, k = (np.asarray(v) for v in conductor_ior("Au"))
    expected = ((eta - 1) ** 2 + k ** 2) / ((eta + 1) ** 2 + k ** 2)
    cam = rt.Camera(lookfrom=(0, 0, -1), lookat=(0, 0, 0), vup=(0, 1, 0), vfov=1.0, width=1, height=1)
    mirror = rt.Quad((-10, -10, 0), (0, 20, 0), (20, 0, 0), rt.Metal(1.0, material="Au"))  # normal -z
    scene = rt.Scene(camera=cam, shapes=[mirror], max_depth=2, background=1.0)
    img = rt.render(scene, spp=16, strategy="mis", seed=0, threads=1).mean[0, 0]
    assert np.allclose(img, expected, rtol=1e-4)
