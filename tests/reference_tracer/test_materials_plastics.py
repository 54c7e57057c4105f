"""Plastics as Mitsuba models them: a diffuse base under a smooth (``plastic``) or rough
(``roughplastic``) dielectric coating.

Here: the rough coating's table against Mitsuba's, the BSDF values and densities against
Mitsuba's own BSDFs, energy, the integrator's treatment of the smooth plastic's Dirac lobe
under every strategy (a closed form), validation, translation and import. (Renders against
Mitsuba's: test_mitsuba_agreement; sampling against the density: test_chi2's catalogue;
scalar against wavefront: test_wavefront.)

Statistical assertions are |z| <= 4 (or z <= 4 where one-sided) under the normal
approximation of a mean of many bounded weights: a false alarm of 6.3e-5 per two-sided
assertion (3.2e-5 one-sided); the seeds are fixed, so a result is reproducible.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

import reference_tracer as rt
from benchmarks.chi2.probes import BsdfProbe, direction
from benchmarks.optics import fresnel_dielectric
from mitsuba_xml import path_integrator, scene_xml
from reference_tracer.probe import rough_plastic_table

ETA = 1.49 / 1.000277   # Mitsuba's default coating: polypropylene in air


def _fdr(e: float) -> float:
    """Mitsuba's fit of the hemispherical mean Fresnel reflectance at relative index e
    (Egan and Hilgeman below 1, d'Eon and Irving above), stated again here."""
    if e < 1:
        return -1.4399 * e * e + 0.7099 * e + 0.6681 + 0.0636 / e
    x = 1 / e
    return 0.919317 - 3.4793 * x + 6.75335 * x**2 - 7.80989 * x**3 + 4.98554 * x**4 - 1.36881 * x**5


def _escape(eta: float) -> float:
    """The integral of (1 - F(cos)) cos / pi over the hemisphere: the share of diffuse
    light that the smooth coating lets out."""
    return integrate.quad(lambda c: (1.0 - fresnel_dielectric(c, eta)) * 2.0 * c, 0.0, 1.0, epsabs=1e-13)[0]


def _smooth_albedo(cos_o, rho, ks, eta=ETA, nonlinear=False):
    """The smooth plastic's directional albedo per channel, from the formulas alone:
    ks F + rho' (1 - F) / eta^2 * the escaping share, rho' = rho / (1 - Fi) (or / (1 - rho Fi))."""
    rho, ks = np.asarray(rho, float), np.asarray(ks, float)
    fi = _fdr(1.0 / eta)
    F = fresnel_dielectric(cos_o, eta)
    base = rho / (1.0 - (rho * fi if nonlinear else fi))
    return ks * F, base * (1.0 - F) / eta**2 * _escape(eta)


# ------------------------------------------------------------------ the rough coating's table
def test_default_table_is_mitsubas_verified_values():
    """Beckmann, alpha 0.1, 1.49 / 1.000277 (Mitsuba's defaults): the values read from Mitsuba
    3.9.1 itself, to their 6 printed decimals."""
    t = rough_plastic_table("beckmann", 0.1, ETA)
    T = t["transmittance"]
    assert T.shape == (64,)
    np.testing.assert_allclose([T[0], T[1], T[2], T[63]], [0.370129, 0.392376, 0.415706, 0.961324], atol=1e-6)
    assert t["internal_reflectance"] == pytest.approx(0.574663, abs=1e-6)


def _mitsuba_table(mi, distribution, alpha, int_ior, ext_ior):
    """Mitsuba's table and internal reflectance, read back through its diffuse lobe's value
    rho' / pi cos_o T(cos_i) T(cos_o) / eta^2 (rho' = rho / (1 - rho Fi) with nonlinear: two
    reflectances give Fi, then T(1), then every T(k / 63))."""
    eta = int_ior / ext_ior
    ctx = mi.BSDFContext()
    ctx.component = 1
    bsdfs = {r: mi.load_dict({"type": "roughplastic", "distribution": distribution, "alpha": alpha,
                              "int_ior": int_ior, "ext_ior": ext_ior, "nonlinear": True,
                              "diffuse_reflectance": {"type": "rgb", "value": [r, r, r]}}) for r in (0.2, 0.9)}

    def value(r, mu_i, mu_o):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(math.sqrt(1 - mu_i * mu_i), 0, mu_i)
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        v = bsdfs[r].eval(ctx, si, mi.Vector3f(-math.sqrt(1 - mu_o * mu_o), 0, mu_o))
        return float(np.ravel(np.array(v))[0])

    v1, v2 = value(0.2, 1, 1), value(0.9, 1, 1)
    fi = (v1 / 0.2 - v2 / 0.9) / (v1 - v2)
    k = lambda v: v * (1 - 0.2 * fi) / 0.2 * math.pi * eta * eta  # noqa: E731  (= cos_o T(cos_i) T(cos_o))
    t1 = math.sqrt(k(v1))
    table = [k(value(0.2, 1e-6, 1.0)) / t1] + [k(value(0.2, 1.0, j / 63)) / (j / 63 * t1) for j in range(1, 64)]
    return np.array(table), fi


@pytest.mark.parametrize("distribution, alpha, int_ior, ext_ior", [
    ("ggx", 0.3, 1.49, 1.000277), ("beckmann", 0.7, 1.5, 1.0), ("ggx", 0.1, 1.9, 1.0),
    ("ggx", 0.2, 1.0, 1.4),   # a coating thinner than the outside
])
def test_table_is_mitsubas(distribution, alpha, int_ior, ext_ior):
    """Our quadrature of Mitsuba's definition gives Mitsuba's table, GGX included: both
    integrate over the square that Mitsuba's visible-normal sampler maps (GGX's polar map,
    the rough conductor's, gives the same integrals with a quadrature error up to 3e-4).
    The bound is the read-back's float32 precision."""
    from mitsuba_scenes.variants import import_mitsuba

    mi = import_mitsuba()
    theirs, fi = _mitsuba_table(mi, distribution, alpha, int_ior, ext_ior)
    ours = rough_plastic_table(distribution, alpha, int_ior / ext_ior)
    assert np.max(np.abs(ours["transmittance"] - theirs)) < 2e-5
    assert ours["internal_reflectance"] == pytest.approx(fi, abs=2e-5)


# ------------------------------------------------------------------ values against Mitsuba's
def _mitsuba_eval_pdf(mi, d, wo, wi):
    """Mitsuba's f cos and pdf at directions wi (our wo, toward the viewer, is its si.wi)."""
    import drjit as dr

    bsdf, ctx = mi.load_dict(d), mi.BSDFContext()
    if mi.variant().startswith("scalar"):
        rows = []
        for w in wi:
            si = mi.SurfaceInteraction3f()
            si.wi, si.sh_frame = mi.Vector3f(*wo), mi.Frame3f(mi.Vector3f(0, 0, 1))
            rows.append((np.array(bsdf.eval(ctx, si, mi.Vector3f(*w))), bsdf.pdf(ctx, si, mi.Vector3f(*w))))
        return np.array([r[0] for r in rows]), np.array([float(r[1]) for r in rows])
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.wi = mi.Vector3f(np.repeat(np.asarray(wo)[None], len(wi), 0).T)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    return (np.array(bsdf.eval(ctx, si, mi.Vector3f(wi.T))).T.reshape(len(wi), 3),
            np.array(bsdf.pdf(ctx, si, mi.Vector3f(wi.T))))


@pytest.mark.parametrize("mitsuba, probe, alpha, coating", [
    ({"type": "plastic"}, "plastic", 0.0, {}),
    ({"type": "plastic", "nonlinear": True, "int_ior": 1.9, "ext_ior": 1.0}, "plastic", 0.0,
     {"nonlinear": True, "eta": 1.9}),
    ({"type": "roughplastic", "distribution": "ggx", "alpha": 0.3}, "rough_plastic", 0.3, {}),
    ({"type": "roughplastic", "alpha": 0.1}, "rough_plastic_beckmann", 0.1, {}),
    ({"type": "roughplastic", "alpha": 0.5, "nonlinear": True, "int_ior": 1.0, "ext_ior": 1.33},
     "rough_plastic_beckmann", 0.5, {"nonlinear": True, "eta": 1.0 / 1.33}),
], ids=["plastic", "plastic_nonlinear_eta", "rough_ggx", "rough_beckmann", "rough_beckmann_nonlinear_thin"])
def test_values_and_densities_are_mitsubas(mitsuba, probe, alpha, coating):
    """f cos and pdf at random direction pairs, ours against Mitsuba's BSDF (single precision:
    1e-4 of the largest value). The Beckmann density differs by design: ours divides by the
    exact masking of the visible normals it samples, Mitsuba's by Walter's approximation of
    it (at most 0.35% apart), so that the estimator is unbiased for Mitsuba's BSDF value."""
    from mitsuba_scenes.variants import import_mitsuba

    mi = import_mitsuba()
    rho, ks = (0.2, 0.5, 0.8), (0.9, 0.7, 0.4)
    d = {**mitsuba, "diffuse_reflectance": {"type": "rgb", "value": list(rho)},
         "specular_reflectance": {"type": "rgb", "value": list(ks)}}
    rng = np.random.default_rng(3)
    for _ in range(3):
        v = rng.normal(size=(301, 3))
        v[:, 2] = np.abs(v[:, 2])
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        wo, wi = v[0], np.ascontiguousarray(v[1:])
        f_mi, pdf_mi = _mitsuba_eval_pdf(mi, d, wo, wi)
        ours = BsdfProbe(probe, wo, param=alpha, albedo=rho, coating={**coating, "specular": ks}).eval_pdf(wi)
        assert np.max(np.abs(ours["value"] - f_mi)) <= 1e-4 * np.max(np.abs(f_mi))
        rtol = 0.0036 if probe == "rough_plastic_beckmann" else 1e-4
        np.testing.assert_allclose(ours["pdf"], pdf_mi, rtol=rtol, atol=1e-6)


# ------------------------------------------------------------------ energy
@pytest.mark.parametrize("alpha", [0.02, 0.1, 0.5, 1.0])
@pytest.mark.parametrize("distribution", ["rough_plastic", "rough_plastic_beckmann"])
@pytest.mark.parametrize("theta", [0, 60, 85])
def test_white_rough_plastic_conserves_energy(theta, distribution, alpha):
    """A white base (rho = 1) under a coating of ks = 1 reflects at most what arrives: the mean
    sample weight (f cos / pdf) is at most 1 within 4 standard errors of 2e5 samples."""
    probe = BsdfProbe(distribution, direction(theta, 40.0), param=alpha, albedo=(1.0, 1.0, 1.0))
    s = probe.sample_full(np.random.default_rng(11).random((200_000, 3)))
    w = np.where(s["valid"].astype(bool), s["weight"][:, 0], 0.0)
    assert np.all(w >= 0)
    assert w.mean() <= 1.0 + 4.0 * w.std() / np.sqrt(w.size)


@pytest.mark.parametrize("theta", [0, 45, 80])
@pytest.mark.parametrize("nonlinear", [False, True])
def test_white_smooth_plastic_reflects_mitsubas_albedo(theta, nonlinear):
    """A white base under a smooth coating: the mean sample weight is the model's albedo
    ks F + (1 - F) escape / (eta^2 (1 - Fi)) within 4 standard errors of 2e5 samples. That
    albedo is Mitsuba's, and is not quite 1: its fit of Fi (0.590479) makes eta^2 (1 - Fi)
    0.1% smaller than the escaping share it should equal, so at the default coating the
    smooth plastic returns 1.0011 of what arrives (asserted: the departure is the model's)."""
    wo = direction(theta, 40.0)
    spec, diff = _smooth_albedo(wo[2], 1.0, 1.0, nonlinear=nonlinear)
    expected = float(spec + diff)
    assert 1.0 < expected < 1.0012
    probe = BsdfProbe("plastic", wo, albedo=(1.0, 1.0, 1.0), coating={"nonlinear": nonlinear})
    s = probe.sample_full(np.random.default_rng(5).random((200_000, 3)))
    w = np.where(s["valid"].astype(bool), s["weight"][:, 0], 0.0)
    assert abs(w.mean() - expected) <= 4.0 * w.std() / np.sqrt(w.size)


# ------------------------------------------------------------------ the integrator
def _facing_plastic(material, theta, *, background=1.0):
    """One pixel looking at the middle of a large quad of ``material`` at ``theta`` from its
    normal, under a constant sky and nothing else: the pixel is the material's directional
    albedo times the sky (max_depth 2: the sky seen after one bounce)."""
    t = math.radians(theta)
    eye = (0.0, 5.0 * math.sin(t), 5.0 * math.cos(t))
    cam = rt.Camera(lookfrom=eye, lookat=(0, 0, 0), vup=(0, 1, 0), vfov=0.01, width=1, height=1)
    quad = rt.Quad((-50, -50, 0), (100, 0, 0), (0, 100, 0), material)   # normal +z
    return rt.Scene(camera=cam, shapes=[quad], max_depth=2, rr_depth=None, background=background)


@pytest.mark.parametrize("strategy", rt.STRATEGIES)
@pytest.mark.parametrize("theta", [20, 70])
def test_smooth_plastic_under_a_uniform_sky_every_strategy(strategy, theta):
    """The pixel equals the closed form ks F + diffuse albedo (independent formulas) for every
    unbiased strategy, within 4 standard errors per channel: `uniform` and `mixture` leave the
    Dirac lobe to the material with its probability, `mis` weighs the sky it meets by 1. The
    `light` strategy shows the diffuse lobe alone (no light sample meets the Dirac lobe)."""
    rho, ks = (0.2, 0.5, 0.8), (0.9, 0.7, 0.4)
    m = rt.Plastic(rho, specular_reflectance=ks)
    spp = 1 << 16
    r = rt.render(_facing_plastic(m, theta), spp=spp, strategy=strategy, seed=9, threads=2)
    spec, diff = _smooth_albedo(math.cos(math.radians(theta)), rho, ks)
    expected = diff if strategy == "light" else spec + diff
    se = np.sqrt(r.variance[0, 0].astype(np.float64) / spp)
    z = (r.mean[0, 0] - expected) / np.maximum(se, 1e-7 * expected)
    assert np.all(np.abs(z) <= 4.0), (r.mean[0, 0], expected, z)


def test_smooth_plastic_sample_is_a_mirror_bounce_for_mis():
    """Under `mis`, sky met through the Dirac lobe is weighted 1 (as after a mirror): with a
    black base the plastic is a Fresnel mirror and every sample is ks F, up to the change of F
    across the pixel's 1.7e-4 rad (1e-4 of the value here). A weight from the power heuristic
    instead (the lobe's probability, 1 here, against the sky's density 1 / 4 pi) would be 0.6%
    low."""
    m = rt.Plastic(0.0, specular_reflectance=(0.9, 0.7, 0.4))
    r = rt.render(_facing_plastic(m, 50), spp=64, strategy="mis", seed=1, threads=1)
    expected = np.array((0.9, 0.7, 0.4)) * fresnel_dielectric(math.cos(math.radians(50)), ETA)
    np.testing.assert_allclose(r.mean[0, 0], expected, rtol=1e-4)
    assert np.all(np.sqrt(r.variance[0, 0]) < 1e-4 * expected)


# ------------------------------------------------------------------ validation
@pytest.mark.parametrize("make, match", [
    (lambda: rt.Plastic(1.2), r"Plastic.diffuse_reflectance must lie in \[0, 1.0\]"),
    (lambda: rt.Plastic((0.5, -0.1, 0.2)), "Plastic.diffuse_reflectance must be >= 0"),
    (lambda: rt.Plastic(0.5, specular_reflectance=(1, 2, 1)), "Plastic.specular_reflectance must lie in"),
    (lambda: rt.Plastic(0.5, int_ior=0.0), "Plastic.int_ior must be > 0"),
    (lambda: rt.Plastic(0.5, ext_ior=float("nan")), "Plastic.ext_ior must be finite"),
    (lambda: rt.Plastic(0.5, int_ior="bk7"), "Plastic.int_ior must be a number"),
    (lambda: rt.Plastic(0.5, int_ior=4.0), "beyond Mitsuba's fit"),
    (lambda: rt.Plastic(0.5, nonlinear="false"), "Plastic.nonlinear must be True or False"),
    (lambda: rt.Plastic(0.5, two_sided=None), "Plastic.two_sided must be True or False"),
    (lambda: rt.RoughPlastic(0.5, int_ior=1.3, ext_ior=1.3), "int_ior and ext_ior must differ"),
    (lambda: rt.RoughPlastic(0.5, alpha=0.0), "RoughPlastic.alpha must be >= 0.0001"),
    (lambda: rt.RoughPlastic(0.5, alpha=5.0), "RoughPlastic.alpha must be <= 4.0"),
    (lambda: rt.RoughPlastic(0.5, distribution="phong"), "RoughPlastic.distribution must be one of"),
    (lambda: rt.RoughPlastic(0.5, nonlinear=2), "RoughPlastic.nonlinear must be True or False"),
])
def test_bad_parameters_are_refused(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_smooth_plastic_takes_equal_indices_as_mitsuba_does():
    """Mitsuba's smooth plastic accepts int_ior == ext_ior (no Fresnel reflection at all); only
    the rough one refuses it."""
    m = rt.Plastic(0.5, int_ior=1.0, ext_ior=1.0)
    s = BsdfProbe("plastic", direction(30.0), albedo=(0.5, 0.5, 0.5), coating={"eta": 1.0}).sample_full(
        np.random.default_rng(0).random((1000, 3)))
    assert m.relative_ior == 1.0 and not s["delta"].any()


# ------------------------------------------------------------------ translation and import
def test_translation_gives_mitsuba_every_parameter():
    from mitsuba_scenes.translate.bsdfs import bsdf_record

    rec = bsdf_record("x", rt.RoughPlastic((0.1, 0.2, 0.3), alpha=0.25, distribution="ggx", int_ior=1.6,
                                            ext_ior=1.1, specular_reflectance=0.8, nonlinear=True, two_sided=True))
    assert rec["type"] == "twosided"
    b = rec["bsdf"]
    assert (b["type"], b["distribution"], b["nonlinear"]) == ("roughplastic", "ggx", True)
    assert b["alpha"] == pytest.approx(0.25) and (b["int_ior"], b["ext_ior"]) == pytest.approx((1.6, 1.1))
    np.testing.assert_allclose(b["diffuse_reflectance"]["value"], (0.1, 0.2, 0.3), rtol=1e-7)
    np.testing.assert_allclose(b["specular_reflectance"]["value"], (0.8, 0.8, 0.8), rtol=1e-7)
    smooth = bsdf_record("x", rt.Plastic(0.5))
    assert smooth["type"] == "plastic" and "alpha" not in smooth and smooth["int_ior"] == pytest.approx(1.49)


def test_xml_round_trip_keeps_every_parameter(tmp_path):
    """to_xml then from_mitsuba gives the same plastics back (to float32, what Mitsuba stores)."""
    from dataclasses import fields

    from mitsuba_scenes import from_mitsuba, to_xml

    mats = [rt.Plastic((0.1, 0.2, 0.3), specular_reflectance=(0.9, 0.8, 0.7), int_ior=1.7, ext_ior=1.2,
                       nonlinear=True),
            rt.RoughPlastic((0.4, 0.5, 0.6), alpha=0.05, distribution="ggx", int_ior=1.0, ext_ior=1.5,
                            specular_reflectance=0.6, two_sided=True),
            rt.RoughPlastic(0.5)]
    cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=4, height=4)
    scene = rt.Scene(camera=cam, shapes=[rt.Sphere((i, 0, 0), 0.2, m) for i, m in enumerate(mats)])
    back = [s.material for s in from_mitsuba(to_xml(scene, tmp_path / "p.xml")).shapes]
    for a, b in zip(mats, back):
        assert type(a) is type(b)
        for f in fields(a):
            va, vb = getattr(a, f.name), getattr(b, f.name)
            if isinstance(va, str) or isinstance(va, bool):
                assert va == vb, f.name
            else:
                np.testing.assert_allclose(vb, va, rtol=1e-6, err_msg=f.name)


def _xml(body: str) -> str:
    return scene_xml(body, integrator=path_integrator(3), fov=40, origin="0, 0, -4", target="0, 0, 0",
                     width=8, height=8)


def test_import_reads_every_parameter(tmp_path):
    from mitsuba_scenes import from_mitsuba

    path = tmp_path / "plastics.xml"
    path.write_text(_xml("""\
        <shape type="sphere">
            <bsdf type="plastic">
                <rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/>
                <rgb name="specular_reflectance" value="0.9, 0.8, 0.7"/>
                <string name="int_ior" value="BK7"/>
                <string name="ext_ior" value="water"/>
                <boolean name="nonlinear" value="true"/>
            </bsdf>
        </shape>
        <shape type="sphere">
            <point name="center" x="2" y="0" z="0"/>
            <bsdf type="twosided">
                <bsdf type="roughplastic">
                    <string name="distribution" value="ggx"/>
                    <float name="alpha" value="0.3"/>
                    <float name="int_ior" value="1.7"/>
                </bsdf>
            </bsdf>
        </shape>
        <shape type="sphere">
            <point name="center" x="-2" y="0" z="0"/>
            <bsdf type="roughplastic"><float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.2"/></bsdf>
        </shape>
        <shape type="sphere">
            <point name="center" x="0" y="2" z="0"/>
            <bsdf type="roughplastic"/>
        </shape>
        """))
    a, b, c, d = (s.material for s in from_mitsuba(path).shapes)
    assert a == rt.Plastic((0.1, 0.2, 0.3), specular_reflectance=(0.9, 0.8, 0.7), int_ior=1.5046, ext_ior=1.333,
                           nonlinear=True)
    assert b == rt.RoughPlastic(0.5, alpha=0.3, distribution="ggx", int_ior=1.7, two_sided=True)
    assert c == rt.RoughPlastic(0.5, alpha=0.2)
    assert d == rt.RoughPlastic(0.5)   # Mitsuba's defaults: Beckmann, 0.1, polypropylene in air


def test_import_refuses_what_is_not_modelled_with_its_place(tmp_path):
    from mitsuba_scenes import from_mitsuba

    path = tmp_path / "bad.xml"
    path.write_text(_xml("""\
        <shape type="sphere">
            <bsdf type="plastic">
                <texture type="checkerboard" name="specular_reflectance"/>
                <string name="int_ior" value="glass"/>
            </bsdf>
        </shape>
        <shape type="sphere">
            <bsdf type="roughplastic">
                <float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/>
                <boolean name="sample_visible" value="false"/>
            </bsdf>
        </shape>
        <shape type="sphere">
            <bsdf type="roughplastic"><float name="int_ior" value="1.333"/><string name="ext_ior" value="water"/></bsdf>
        </shape>
        <shape type="sphere">
            <bsdf type="roughplastic"><string name="distribution" value="phong"/></bsdf>
        </shape>
        <shape type="sphere">
            <bsdf type="plastic"><integer name="int_ior" value="2"/><float name="roughness" value="1"/></bsdf>
        </shape>
        """))
    with pytest.raises(ValueError) as err:
        from_mitsuba(path)
    msg = str(err.value)
    for needle in ("texture 'checkerboard' for plastic.specular_reflectance", "int_ior='glass' is not a known IOR name",
                   "anisotropic roughplastic", "roughplastic sample_visible=false", "roughplastic distribution 'phong'",
                   "int_ior and ext_ior must differ", "plastic int_ior of type", "parameter 'roughness' is not supported"):
        assert needle in msg, (needle, msg)
    assert "bad.xml (line" in msg


def test_a_veach_scene_with_rough_plastic_plates_imports():
    """The plates of Mitsuba's documentation scene of Veach's MIS test (include/veach_mis.xml:
    roughplastic, Beckmann by default, int_ior 2, alpha 0.005 to 0.1) import as RoughPlastic."""
    from mitsuba_scenes import from_mitsuba

    plates = {f"plate{i}": {"type": "rectangle", "to_world": _translate(0, i, 0),
                            "bsdf": {"type": "roughplastic", "int_ior": 2.0, "alpha": a,
                                     "diffuse_reflectance": {"type": "rgb", "value": [0.07, 0.09, 0.13]},
                                     "specular_reflectance": {"type": "rgb", "value": [1, 1, 1]}}}
              for i, a in enumerate((0.005, 0.02, 0.05, 0.1))}
    d = {"type": "scene", "integrator": {"type": "path"},
         "sensor": {"type": "perspective", "film": {"type": "hdrfilm", "width": 8, "height": 8,
                                                     "rfilter": {"type": "box"}}}, **plates}
    mats = [s.material for s in from_mitsuba(d).shapes]
    assert [m.alpha for m in mats] == pytest.approx([0.005, 0.02, 0.05, 0.1])
    assert all(m.distribution == "beckmann" and m.int_ior == 2.0 and m.ext_ior == pytest.approx(1.000277)
               for m in mats)


def _translate(x, y, z):
    from mitsuba_scenes.variants import import_mitsuba

    mi = import_mitsuba()
    return mi.ScalarTransform4f().translate([x, y, z])
