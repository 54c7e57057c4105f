"""Chi-square tests of the sampling routines (issue 18) and of the test itself.

* Every routine of ``benchmarks.chi2.catalogue.ROUTINES`` passes at n = 1e5 samples (2e6
  behind ``slow``). All routine tests of one size together have a false-positive rate of
  at most 1% (Sidak: each routine is tested at 1 - 0.99^(1/k) for the k routines, and
  splits that over its own statistical sub-tests the same way). The seeds are fixed, so
  a pass is reproducible; a change of seed fails spuriously with probability <= 1%.
* Deliberately wrong densities fail (a cosine sampler against the uniform pdf, a pdf
  scaled by 1.1, a GGX pdf with a 10% wrong alpha, a light pdf evaluated from the wrong
  point, Schlick's reflectance against exact Fresnel): each of these is rejected with
  p < 1e-10 at the sizes used, so the chance of a spurious pass is negligible.
* The statistics: Sidak's formula, pooling, the quadrature, and the calibration of the
  p-values (uniform under the null hypothesis; KS test at level 1e-3).
"""
import json
import math

import numpy as np
import pytest
from scipy import stats

from benchmarks.chi2 import Grid, chi2_test, discrete_test, integrate, pearson, sidak
from benchmarks.chi2.catalogue import ROUTINES, select
from benchmarks.chi2.runner import Routine
from benchmarks.chi2.runner import run_routine
from benchmarks.chi2.probes import BsdfProbe, LightProbe, direction, fresnel_schlick, warp
from benchmarks.optics import fresnel_dielectric

ALPHA_FAMILY = 0.01
PER_ROUTINE = sidak(ALPHA_FAMILY, len(ROUTINES))


# --- every routine passes --------------------------------------------------------------

@pytest.mark.parametrize("routine", ROUTINES, ids=[r.label for r in ROUTINES])
def test_routine_passes(routine):
    row = run_routine(routine, n=100_000, seed=0, alpha=PER_ROUTINE)
    assert row.verdict == "pass", (row.message, row.checks)


@pytest.mark.slow
@pytest.mark.parametrize("routine", ROUTINES, ids=[r.label for r in ROUTINES])
def test_routine_passes_large_n(routine):
    row = run_routine(routine, n=2_000_000, seed=1, alpha=PER_ROUTINE)
    assert row.verdict == "pass", (row.message, row.checks)


def test_catalogue_covers_every_routine():
    names = {r.name for r in ROUTINES}
    assert {"warp.uniform_hemisphere", "warp.cosine_hemisphere", "warp.uniform_sphere", "warp.uniform_cone",
            "warp.concentric_disk", "bsdf.lambertian", "bsdf.rough_conductor", "bsdf.rough_conductor_beckmann",
            "bsdf.plastic", "bsdf.rough_plastic", "bsdf.rough_plastic_beckmann", "bsdf.rough_dielectric",
            "bsdf.rough_dielectric_beckmann", "lobes.dielectric",
            "lobes.dielectric_schlick", "light.quad", "light.triangle", "light.smooth_triangle", "light.sphere",
            "light.scene", "light.envmap", "light.scene_envmap"} <= names
    ggx = [dict(r.params) for r in ROUTINES if r.name == "bsdf.rough_conductor"]
    assert len({p["alpha"] for p in ggx}) >= 3 and len({p["theta_o"] for p in ggx}) >= 3
    for name in ("bsdf.rough_plastic", "bsdf.rough_plastic_beckmann", "bsdf.plastic"):
        ps = [dict(r.params) for r in ROUTINES if r.name == name]
        assert len({p["theta_o"] for p in ps}) >= 4 and any(p.get("nonlinear") for p in ps)
        assert any(p.get("eta", 1.5) < 1 for p in ps) or name == "bsdf.rough_plastic"
        if name != "bsdf.plastic":
            assert len({p["alpha"] for p in ps}) >= 3
    spheres = " ".join(dict(r.params)["ref"] for r in ROUTINES if r.name == "light.sphere")
    assert "outside" in spheres and "inside" in spheres and "on the surface" in spheres
    assert len({r.label for r in ROUTINES}) == len(ROUTINES)


def test_row_json_round_trips():
    row = run_routine(select(["bsdf.lambertian"])[0], n=20_000, seed=0)
    doc = json.loads(json.dumps(row.to_json()))
    assert doc["verdict"] == "pass" and doc["routine"] == "bsdf.lambertian" and doc["n"] == 20_000
    assert doc["checks"]["weight_is_eval_over_pdf"]["ok"]


# --- wrong densities fail ---------------------------------------------------------------

def test_cosine_sampler_with_uniform_pdf_fails():
    sample, _ = warp("cosine_hemisphere")
    _, uniform_pdf = warp("uniform_hemisphere")
    r = chi2_test(sample, uniform_pdf, domain="hemisphere", n=50_000, seed=3)
    assert r.verdict == "fail" and r.p_value < 1e-10
    assert r.mass_p_value == 1.0   # right mass, wrong shape: the distribution test catches it


def test_pdf_scaled_by_1_1_fails_on_mass():
    sample, pdf = warp("cosine_hemisphere")
    r = chi2_test(sample, lambda d: 1.1 * pdf(d), domain="hemisphere", n=50_000, seed=3)
    assert r.verdict == "fail" and r.mass_p_value < 1e-10 and "integrates to 1.1" in r.message
    assert r.p_value > 1e-3        # the shape is right: only the mass check can see a scale


@pytest.mark.parametrize("material", ["rough_conductor", "rough_conductor_beckmann"])
@pytest.mark.parametrize("theta", [0, 60])
def test_microfacet_pdf_with_wrong_alpha_fails(theta, material):
    right = BsdfProbe(material, direction(theta, 40.0), param=0.3)
    wrong = BsdfProbe(material, direction(theta, 40.0), param=0.33)
    r = chi2_test(right.sample, wrong.pdf, domain="hemisphere", n=100_000, seed=5, dims=3)
    assert r.verdict == "fail" and min(r.p_value, r.mass_p_value) < 1e-10


@pytest.mark.parametrize("change", [{"coating": {"eta": 2.5}}, {"material": "rough_plastic_beckmann"},
                                    {"albedo": (0.4, 0.3, 0.2)}], ids=["eta", "distribution", "sampling_weight"])
def test_rough_plastic_pdf_of_another_plastic_fails(change):
    """The density of a rough plastic with another coating index (its table and lobe choice:
    1.49 against 2.5; against 1.6 the lobe probabilities differ too little for 1e5 samples),
    another distribution, or another diffuse reflectance (Mitsuba's sampling weight)."""
    kw = dict(material="rough_plastic", wo=direction(60.0, 40.0), param=0.3)
    right = BsdfProbe(**kw)
    wrong = BsdfProbe(**{**kw, **change})
    r = chi2_test(right.sample, wrong.pdf, domain="hemisphere", n=100_000, seed=5, dims=3)
    assert r.verdict == "fail" and min(r.p_value, r.mass_p_value) < 1e-10


def test_smooth_plastic_specular_share_without_the_sampling_weight_fails():
    """The share of specular samples is Mitsuba's F sw / (F sw + (1 - F)(1 - sw)), not F."""
    probe = BsdfProbe("plastic", direction(60.0, 25.0))
    s = probe.sample_full(np.random.default_rng(4).random((100_000, 3)))
    specular = int(s["delta"].sum())
    F = fresnel_dielectric(float(probe.wo[2]), 1.49 / 1.000277)
    r = discrete_test([specular, 100_000 - specular], [F, 1 - F], alpha=0.01)
    assert r.verdict == "fail" and r.p_value < 1e-10


def test_light_pdf_from_the_wrong_point_fails():
    import reference_tracer as rt

    quad = [rt.Quad((-1.0, 1.0, -1.0), (2.0, 0.0, 0.0), (0.0, 0.0, 2.0), rt.DiffuseLight(1.0))]
    right = LightProbe(quad, np.array([0.3, 0.4, -0.2]))
    moved = LightProbe(quad, np.array([0.3, 0.35, -0.2]))
    r = chi2_test(right.sample, moved.pdf, domain="sphere", n=100_000, seed=2, dims=3)
    assert r.verdict == "fail" and r.p_value < 1e-10


def test_smooth_light_draws_by_area_not_by_its_reported_density():
    """A triangle light with leaning vertex normals reports Mitsuba's density, with the shading
    cosine (light_pdf); the directions it draws follow the geometric cosine. Tested against
    the reported density, the draw fails: the catalogue's routine rightly takes the other."""
    import reference_tracer as rt

    tri = [(-1.0, 1.0, -1.0), (1.0, 1.0, -1.0), (0.0, 1.0, 1.0)]
    normals = [(0.6, -1.0, 0.0), (-0.3, -1.0, 0.5), (0.0, -1.0, -0.8)]
    probe = LightProbe([rt.Mesh(tri, [[0, 1, 2]], rt.DiffuseLight(1.0), normals=normals)], np.array([0.2, 0.3, 0.1]))
    r = chi2_test(probe.sample, probe.pdf, domain="sphere", n=100_000, seed=2, dims=3)
    assert r.verdict == "fail" and min(r.p_value, r.mass_p_value) < 1e-10


def _envmap_probe(image, **kw):
    import reference_tracer as rt

    env = rt.EnvMap(image, **kw)
    return env, LightProbe([], np.zeros(3), lights=(env,))


def test_envmap_sampling_against_wrong_densities_fails():
    """The environment map's sampler against its density stated independently passes (the
    catalogue's test); against the same cells uniform in (u, v) instead of in solid angle (no
    sin theta: too much density at the poles), against the map rotated by a tenth of a texel
    column, or with the cells' weights taken from their first corner alone, it fails."""
    from benchmarks.chi2.catalogue import _envmap_density, _envmap_image

    img = _envmap_image(11, (8, 16), sun=(2, 9))
    env, probe = _envmap_probe(img)
    right = chi2_test(probe.sample, _envmap_density(env), domain="sphere", n=100_000, seed=6, dims=3)
    assert right.verdict == "pass"

    h, w = env.height, env.width
    lum = np.asarray(env.pixels, float) @ np.array([0.2126, 0.7152, 0.0722])
    cell = 0.25 * (lum[:-1] + np.roll(lum[:-1], -1, axis=1) + lum[1:] + np.roll(lum[1:], -1, axis=1))

    def uv_density(dirs):   # piecewise constant in (u, v): p(omega) = p(u, v) / (2 pi^2 sin theta)
        u = np.mod(np.arctan2(dirs[:, 0], -dirs[:, 2]) / (2 * np.pi), 1.0)
        theta = np.arccos(np.clip(dirs[:, 1], -1, 1))
        j = np.mod(np.floor(u * w - 0.5).astype(int), w)
        k = np.minimum(np.floor(theta / np.pi * (h - 1)).astype(int), h - 2)
        p_uv = cell[k, j] / (cell.sum() / (w * (h - 1)))
        return p_uv / (2 * np.pi ** 2 * np.maximum(np.sin(theta), 1e-12))
    wrong_uv = chi2_test(probe.sample, uv_density, domain="sphere", n=100_000, seed=6, dims=3)
    assert wrong_uv.verdict == "fail" and min(wrong_uv.p_value, wrong_uv.mass_p_value) < 1e-10

    a = 2 * np.pi / w / 10   # a tenth of a column, about the vertical axis
    turned = _envmap_density(_envmap_probe(img, to_world=[[np.cos(a), 0, np.sin(a)], [0, 1, 0],
                                                          [-np.sin(a), 0, np.cos(a)]])[0])
    wrong_turn = chi2_test(probe.sample, turned, domain="sphere", n=100_000, seed=6, dims=3)
    assert wrong_turn.verdict == "fail" and wrong_turn.p_value < 1e-10

    corner = lum[:-1] / float((lum[:-1] * ((2 * np.pi / w) * (np.cos(np.arange(h - 1) * np.pi / (h - 1))
                                                             - np.cos(np.arange(1, h) * np.pi / (h - 1))))[:, None]).sum())

    def corner_density(dirs):
        u = np.mod(np.arctan2(dirs[:, 0], -dirs[:, 2]) / (2 * np.pi), 1.0)
        v = np.arccos(np.clip(dirs[:, 1], -1, 1)) / np.pi
        j = np.mod(np.floor(u * w - 0.5).astype(int), w)
        k = np.minimum(np.floor(v * (h - 1)).astype(int), h - 2)
        return corner[k, j]
    wrong_corner = chi2_test(probe.sample, corner_density, domain="sphere", n=100_000, seed=6, dims=3)
    assert wrong_corner.verdict == "fail" and min(wrong_corner.p_value, wrong_corner.mass_p_value) < 1e-10


def test_disk_with_a_linear_radius_fails():
    def polar(u):   # r = u1 instead of sqrt(u1): too many points near the centre
        r, phi = u[:, 0], 2 * np.pi * u[:, 1]
        return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=1)
    _, pdf = warp("concentric_disk")
    r = chi2_test(polar, pdf, domain="disk", n=50_000, seed=0)
    assert r.verdict == "fail" and r.p_value < 1e-10


def test_schlick_lobes_against_exact_fresnel_fail():
    probe = BsdfProbe("dielectric_schlick", direction(80.0, 25.0), param=1.5)
    s = probe.sample_full(np.random.default_rng(4).random((200_000, 3)))
    reflected = int(np.all(np.isclose(s["wi"], [-probe.wo[0], -probe.wo[1], probe.wo[2]]), axis=1).sum())
    F = fresnel_dielectric(float(probe.wo[2]), 1.5)
    assert abs(F - fresnel_schlick(float(probe.wo[2]), 1.5)) > 0.01
    r = discrete_test([reflected, 200_000 - reflected], [F, 1 - F], alpha=0.01)
    assert r.verdict == "fail" and r.p_value < 1e-10


def test_samples_outside_the_domain_fail():
    sample, _ = warp("uniform_sphere")
    _, pdf = warp("uniform_hemisphere")
    r = chi2_test(sample, pdf, domain="hemisphere", n=10_000, seed=0)
    assert r.verdict == "fail" and "outside the hemisphere" in r.message


def test_samples_where_the_pdf_is_zero_fail():
    sample, _ = warp("uniform_cone", 0.5)
    _, pdf = warp("uniform_cone", 0.3)    # narrower support than the samples
    r = chi2_test(sample, pdf, domain="sphere", n=20_000, seed=0)
    assert r.verdict == "fail" and "where the pdf is 0" in r.message


def test_a_failing_routine_exits_1(monkeypatch, tmp_path):
    from benchmarks import cli
    from benchmarks.chi2 import catalogue

    def make():
        sample, _ = warp("cosine_hemisphere")
        _, pdf = warp("uniform_hemisphere")
        return {"sample": sample, "pdf": pdf, "domain": "hemisphere", "dims": 2}
    broken = Routine("warp.broken", (), "warp", make)
    monkeypatch.setattr(catalogue, "ROUTINES", (broken,))
    out = tmp_path / "out"
    assert cli.main(["chi2", "--samples", "20000", "--out", str(out), "--images", "failures",
                     "--json", str(tmp_path / "rows.json")]) == 1
    assert (out / "warp.broken.png").exists()
    assert json.loads((tmp_path / "rows.json").read_text())[0]["verdict"] == "fail"


def test_cli_passes_writes_images_and_rejects_bad_usage(tmp_path, capsys):
    from benchmarks import cli

    out = tmp_path / "out"
    assert cli.main(["chi2", "--routine", "warp.cosine", "--routine", "lobes.dielectric[ior=1.5, theta_o=45",
                     "--samples", "20000", "--out", str(out), "--json", str(tmp_path / "rows.json")]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "lobes.dielectric-ior=1.5-theta_o=45-side=outside.png", "warp.cosine_hemisphere.png"]
    rows = json.loads((tmp_path / "rows.json").read_text())
    assert [r["verdict"] for r in rows] == ["pass", "pass"]
    assert "warp.cosine_hemisphere" in capsys.readouterr().out
    assert cli.main(["chi2", "--routine", "no.such.routine"]) == 2
    assert cli.main(["chi2", "--routine", "warp.cosine", "--samples", "0"]) == 2
    assert cli.main(["chi2", "--routine", "warp.cosine", "--alpha", "1.5"]) == 2


# --- the statistics ----------------------------------------------------------------------

def test_sidak():
    assert sidak(0.01, 1) == pytest.approx(0.01, rel=1e-12)
    assert sidak(0.05, 10) == pytest.approx(1 - 0.95 ** 0.1, rel=1e-12)
    assert 1 - (1 - sidak(0.01, 43)) ** 43 == pytest.approx(0.01, rel=1e-9)
    with pytest.raises(ValueError):
        sidak(0.0, 3)


def test_pooling_follows_mitsuba_and_keeps_the_leftover():
    # expected 1, 2, 3 pool into one bin of 6; 10 and 20 stand alone; the zero cell is left out
    stat, bins, pooled_in, pooled_out, stray = pearson([2, 1, 3, 12, 18, 0], [1, 2, 3, 10, 20, 0])
    assert (bins, pooled_in, pooled_out, stray) == (3, 3, 1, 0)
    assert stat == pytest.approx(0 / 6 + 4 / 10 + 4 / 20)
    # a pool still short of 5 takes in the next cell, whatever its size
    stat, bins, pooled_in, _, _ = pearson([0, 2, 30], [1, 1, 30])
    assert bins == 1 and pooled_in == 3 and stat == 0.0
    # a leftover pool at the end (expected 3 < 5) is merged into the last bin, not dropped
    stat, bins, pooled_in, pooled_out, _ = pearson([3, 4, 1], [3, 3, 3])
    assert (bins, pooled_in, pooled_out) == (1, 3, 1) and stat == pytest.approx(1 / 9)
    # samples where nothing is expected
    assert pearson([3, 5], [0, 8])[4] == 3


def test_quadrature_is_exact_for_smooth_and_edge_densities():
    g = Grid.make("hemisphere", (16, 32))
    cos_lobe, err, _, bad = integrate(lambda d: d[:, 2] / np.pi, g, n=10**6)
    assert cos_lobe.sum() == pytest.approx(1.0, abs=1e-6) and bad == 0
    # a cone whose edge cuts a row of cells at the same place in every cell (the case that
    # fools a plain difference test between a rectangle and its quarters)
    cm = 0.7342823073671614
    cone = Grid.make("sphere", (32, 64), cos_range=(0.7289679535145046, 1.0))
    vals, err, _, _ = integrate(lambda d: np.where(d[:, 2] >= cm, 1 / (2 * np.pi * (1 - cm)), 0.0), cone, n=10**6)
    assert vals.sum() == pytest.approx(1.0, abs=5e-5)
    row0 = (cone.lo + (cone.hi - cone.lo) / 32 - cm) / (1 - cm) / 64
    assert np.allclose(vals[0], row0, rtol=2e-3)


def test_quadrature_finds_a_sliver_of_support_between_its_nodes():
    # A density on a band of azimuth 2e-5 wide inside one cell (as the tip of a triangle light
    # seen at a grazing angle): no Lobatto node of the cell lies on it. Where samples fall in
    # that cell, its integral is taken by stratified Monte Carlo and must be the band's mass;
    # without samples there the cell keeps the nodes' 0 (nothing says a sliver is there).
    g = Grid.make("hemisphere", (8, 16))
    lo, width = 0.3 * 2 * np.pi / 16, 2e-5
    value = 1.0 / (width * 1.0)   # uniform over the band (solid angle width x 1): mass 1

    def band(d):
        phi = np.mod(np.arctan2(d[:, 1], d[:, 0]), 2 * np.pi)
        return np.where((phi >= lo) & (phi < lo + width), value, 0.0)

    observed = np.zeros(8 * 16, np.int64)
    observed[3 * 16 + 0] = 7   # samples in cell (3, 0): its share of the band is 1/8
    vals, err, _, bad = integrate(band, g, n=10**6, observed=observed)
    # within 4 of its reported standard errors (seeded, so deterministic), and that error
    # well below the mass: about 50 of the 2^20 points land on the band
    assert bad == 0 and abs(vals[3, 0] - 1 / 8) < 4 * err and err < 0.2 / 8
    assert vals.sum() == vals[3, 0]   # the other cells hold no samples: their nodes' 0
    plain, _, _, _ = integrate(band, g, n=10**6)
    assert plain.sum() == 0.0


def test_p_values_are_uniform_under_the_null():
    """40 tests of a correct sampler: the p-values must look uniform (KS, level 1e-3)."""
    sample, pdf = warp("cosine_hemisphere")
    ps = [chi2_test(sample, pdf, domain="hemisphere", n=5_000, seed=100 + s, resolution=(8, 16)).p_value
          for s in range(40)]
    assert stats.kstest(ps, "uniform").pvalue > 1e-3


@pytest.mark.slow
def test_p_values_are_uniform_under_the_null_many_seeds():
    sample, pdf = warp("uniform_sphere")
    ps = [chi2_test(sample, pdf, domain="sphere", n=20_000, seed=1000 + s, resolution=(16, 32)).p_value
          for s in range(300)]
    assert stats.kstest(ps, "uniform").pvalue > 1e-3


def test_schlick_reference():
    assert fresnel_schlick(1.0, 1.5) == pytest.approx(0.04)
    assert fresnel_schlick(-math.cos(math.radians(60)), 1.5) == 1.0         # total internal reflection


# --- the angle of the azimuthal warps ----------------------------------------------------

@pytest.mark.parametrize("name", ["uniform_sphere", "uniform_hemisphere", "uniform_cone"])
def test_azimuth_sin_cos_match_libm(name):
    # The warps take sin and cos of phi = 2 pi u2 from an inline polynomial after a
    # quarter-turn reduction (warp.h: sincos_turn), not from libm. Against sin/cos of the
    # exact angle in extended precision (x87 long double: 2 pi u in double is itself off
    # by up to 7e-16): within 3e-16 everywhere, including the quarter and eighth turns
    # where the reduction switches quadrant, and both ends.
    from reference_tracer.probe import warp_sample

    rng = np.random.default_rng(5)
    u = rng.random((200_000, 2))
    turns = np.array([0.0, 1 / 8, 1 / 4, 3 / 8, 1 / 2, 5 / 8, 3 / 4, 7 / 8, 1.0])
    near = np.concatenate([turns, np.nextafter(turns, 0.0), np.nextafter(turns, 1.0)])
    u[: len(near), 1] = np.clip(near, 0.0, 1.0)
    param = 0.3 if name == "uniform_cone" else 0.0
    d = warp_sample(name, np.ascontiguousarray(u), param)
    if np.finfo(np.longdouble).eps > 1e-18:
        pytest.skip("no extended-precision long double here")
    radius = np.hypot(d[:, 0], d[:, 1]).astype(np.longdouble)
    phi = 2 * np.arccos(np.longdouble(-1)) * u[:, 1].astype(np.longdouble)
    expected = np.stack([radius * np.cos(phi), radius * np.sin(phi)], axis=1)
    assert float(np.max(np.abs(d[:, :2] - expected))) < 3e-16
    assert np.max(np.abs(np.linalg.norm(d, axis=1) - 1.0)) < 4e-16
