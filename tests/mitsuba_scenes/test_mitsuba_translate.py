"""Translation to Mitsuba: dicts load, XML renders as the dict, refusals, variants, batching."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import get_scene, list_scenes, render_mitsuba, to_mitsuba, to_xml
from mitsuba_scenes.render import batch_estimate, batch_seeds, mesh_merge_safe, split_spp
from mitsuba_scenes.scenes.cornell_mesh import torus
from mitsuba_scenes.translate import look_at_matrix, mitsuba_rr_depth
from mitsuba_scenes.variants import (find_libllvm, import_mitsuba, llvm_target, select_variant, set_llvm_target,
                                     versions)

from build_util import cpu_flags


@pytest.fixture(scope="module")
def mi():
    return import_mitsuba()


@pytest.mark.parametrize("name", list_scenes())
def test_dict_loads_and_xml_renders_the_same(name, mi, tmp_path):
    scene = get_scene(name, width=12, height=8)
    d = to_mitsuba(scene)
    assert d["sensor"]["fov_axis"] == "y" and d["sensor"]["film"]["rfilter"] == {"type": "box"}
    assert d["sensor"]["sampler"]["type"] == "independent"
    opt = mesh_merge_safe(scene)
    a = np.array(mi.render(mi.load_dict(d, optimize=opt), spp=8, seed=11))
    path = to_xml(scene, tmp_path / f"{name}.xml")
    b = np.array(mi.render(mi.load_file(str(path), optimize=opt), spp=8, seed=11))
    assert a.shape == (8, 12, 3) and np.all(np.isfinite(a))
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)


def test_xml_writes_meshes_as_ply_beside_it(tmp_path):
    to_xml(get_scene("cornell_mesh", width=8, height=8), tmp_path / "s.xml")
    plys = list(tmp_path.glob("s_*.ply"))
    assert len(plys) == 1
    text = (tmp_path / "s.xml").read_text()
    assert 'value="true"' in text and "face_normals" in text and "<rfilter type=\"box\"/>" in text


def test_look_at_matches_mitsuba(mi):
    args = ((1, 2, 3), (4, -5, 6), (0.2, 1, 0.3))
    ref = np.array(mi.ScalarTransform4f().look_at(*args).matrix)
    np.testing.assert_allclose(look_at_matrix(*args), ref, atol=1e-6)


def test_rr_depth_mapping():
    assert mitsuba_rr_depth(50, None) == 51
    assert mitsuba_rr_depth(-1, None) == 2**31 - 1
    assert mitsuba_rr_depth(10, 3) == 3


def test_materials_translate_exactly():
    cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=4, height=4)
    mats = [rt.Lambertian(0.5, two_sided=True), rt.Metal((0.9, 0.8, 0.7)), rt.Dielectric(1.33),
            rt.RoughConductor(0.9, alpha=0.3), rt.DiffuseLight(3.0), rt.DiffuseLight(2.0, albedo=0.4)]
    scene = rt.Scene(camera=cam, shapes=[rt.Sphere((i, 0, 0), 0.2, m) for i, m in enumerate(mats)],
                     background=(0.1, 0.2, 0.3))
    d = to_mitsuba(scene)
    shapes = [d[k] for k in sorted(d) if k.startswith("shape_")]
    assert shapes[0]["bsdf"]["type"] == "twosided" and shapes[0]["bsdf"]["bsdf"]["type"] == "diffuse"
    assert shapes[1]["bsdf"] == {"type": "conductor", "material": "none",
                                 "specular_reflectance": {"type": "rgb", "value": pytest.approx([0.9, 0.8, 0.7])}}
    assert shapes[2]["bsdf"]["ext_ior"] == 1.0 and shapes[2]["bsdf"]["int_ior"] == pytest.approx(1.33)
    assert shapes[3]["bsdf"]["distribution"] == "ggx" and shapes[3]["bsdf"]["material"] == "none"
    assert shapes[4]["bsdf"]["reflectance"]["value"] == [0.0, 0.0, 0.0] and shapes[4]["emitter"]["type"] == "area"
    assert shapes[5]["bsdf"]["reflectance"]["value"] == pytest.approx([0.4] * 3)
    assert d["background"]["type"] == "constant"


def test_fuzzy_metal_refused_naming_every_object():
    cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=4, height=4)
    scene = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1, rt.Metal(0.8, fuzz=0.3)),
                                         rt.Quad((0, 0, 0), (1, 0, 0), (0, 1, 0), rt.Lambertian(0.5)),
                                         rt.Sphere((1, 0, 0), 1, rt.Metal(0.8, fuzz=0.1))])
    with pytest.raises(ValueError, match=r"shapes\[0\].*fuzz=0.3(.|\n)*shapes\[2\].*fuzz=0.1"):
        to_mitsuba(scene)


def test_torus_winding_is_outward():
    v, f = torus(major=2.0, minor=0.5, segments=12, rings=8)
    tri = v[f]
    signed_volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6
    assert signed_volume == pytest.approx(2 * np.pi**2 * 2.0 * 0.25, rel=0.15)


def test_split_spp_and_seeds():
    assert split_spp(10, 4) == [3, 3, 2, 2] and sum(split_spp(1000, 7)) == 1000
    assert split_spp(1, 16) == [1]
    s = batch_seeds(5, 100)
    assert len(set(s)) == 100 and min(np.diff(sorted(s))) > 1000
    assert batch_seeds(5, 3) == s[:3] and batch_seeds(6, 3) != s[:3]


def test_batch_estimate_pools_batches_of_unequal_sizes():
    # batches of 3, 3, 2, 2 samples: the mean is the mean of all ten samples, and the
    # between-batch variance is unbiased for the per-sample variance (here over many pixels)
    rng = np.random.default_rng(3)
    sizes = split_spp(10, 4)
    samples = rng.normal(1.0, 2.0, size=(10, 200, 100, 3))
    groups = np.split(samples, np.cumsum(sizes)[:-1])
    mean, var = batch_estimate([g.mean(axis=0) for g in groups], sizes)
    assert mean.dtype == var.dtype == np.float32
    np.testing.assert_allclose(mean, samples.mean(axis=0), rtol=1e-6, atol=1e-6)
    assert float(var.mean()) == pytest.approx(4.0, rel=0.02)
    one_mean, one_var = batch_estimate([samples[0]], [1])
    assert np.array_equal(one_mean, samples[0].astype(np.float32)) and np.isnan(one_var).all()


def test_render_mitsuba_result_and_spp_edge_cases():
    scene = get_scene("cornell_box", width=8, height=8, max_depth=3)
    r = render_mitsuba(scene, spp=5, seed=2, batches=2, threads=1)
    mean, var, sec = r
    assert mean.shape == var.shape == (8, 8, 3) and mean.dtype == np.float32
    assert r.batch_spp == [3, 2] and sec > 0 and r.variant == versions()["variant"]
    assert np.all(var >= 0) and np.all(np.isfinite(var))
    one = render_mitsuba(scene, spp=1, seed=2, threads=1)
    assert one.batches == 1 and np.all(np.isnan(one.variance))
    with pytest.raises(ValueError, match="spp"):
        render_mitsuba(scene, spp=0)


def test_render_mitsuba_variance_is_per_sample():
    """Between-batch variance times batch spp estimates the per-sample variance.

    A diffuse sphere under a constant sky: every sample lies in [0, 1], so the
    per-sample variance is well estimated. 1-spp batches (the plain sample variance)
    and 16-spp batches must give the same mean per-pixel variance: over 8 x 8 x 3
    values with 15 degrees of freedom each, the coarse estimate's relative standard
    error is about sqrt(2/15)/sqrt(64) = 4.6 %, so 20 % is a 4-sigma bound.
    """
    cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), vfov=40, width=8, height=8)
    scene = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1.0, rt.Lambertian(0.7))], max_depth=3,
                     background=1.0)
    fine = render_mitsuba(scene, spp=256, seed=4, batches=256, threads=2)
    coarse = render_mitsuba(scene, spp=256, seed=9, batches=16, threads=2)
    assert fine.variance.mean() > 0.01
    assert coarse.variance.mean() == pytest.approx(fine.variance.mean(), rel=0.2)


def test_variant_selection(monkeypatch, caplog):
    assert select_variant("scalar_rgb") == "scalar_rgb"
    monkeypatch.setenv("RTBENCH_MITSUBA_VARIANT", "scalar_rgb")
    assert select_variant() == "scalar_rgb"
    with pytest.raises(ValueError, match="RGB variant"):
        select_variant("scalar_spectral")
    monkeypatch.delenv("RTBENCH_MITSUBA_VARIANT")
    chosen = select_variant()
    assert chosen in ("cuda_ad_rgb", "llvm_ad_rgb", "scalar_rgb")
    v = versions()
    assert v["mitsuba"] == "3.9.1" and v["variant"] == chosen
    for p in find_libllvm():
        assert "LLVM-15" not in p and "LLVM-14" not in p


@pytest.mark.skipif(not os.path.exists("/proc/cpuinfo"), reason="reads the CPU's flags from /proc/cpuinfo")
def test_llvm_target_reports_the_width_dr_jit_compiles_for():
    # Dr.Jit compiles 16-wide kernels where the CPU has AVX-512 and 8-wide ones with AVX2
    # (as on a Sapphire Rapids host and on an AVX2 machine: PERFORMANCE.md, How to measure),
    # and the benchmark's footer prints it; so must llvm_target.
    try:
        select_variant("llvm_ad_rgb")
    except (RuntimeError, ValueError) as e:
        pytest.skip(f"llvm_ad_rgb does not run here: {e}")
    target = llvm_target()
    assert target is not None and target["cpu"]
    assert target["avx512"] == ("avx512f" in cpu_flags())
    assert target["vector_width"] == (16 if target["avx512"] else 8)
    assert versions()["llvm_target"] == target


_AVX2_KERNELS = """
import numpy as np
from mitsuba_scenes import get_scene, to_mitsuba
from mitsuba_scenes.variants import llvm_target, select_variant, set_llvm_target
select_variant("llvm_ad_rgb")
import mitsuba as mi
before = llvm_target()
if WIDTH:
    for bad in (("haswell", 3), ("", 8)):
        try:
            set_llvm_target(bad[0], "+avx2", bad[1])
        except ValueError as e:
            print("refused:", e)
    after = set_llvm_target("haswell", "+avx,+avx2,+fma,+f16c", WIDTH)
    print(before["vector_width"], after["vector_width"], after["cpu"], after["avx512"], llvm_target() == after)
scene = mi.load_dict(to_mitsuba(get_scene("cornell_box", width=32, height=32)))
print(float(np.array(mi.render(scene, spp=64, seed=3)).mean()))
try:
    set_llvm_target("haswell", "+avx2", 8)
except RuntimeError as e:
    print("refused:", e)
"""


def _kernels(width):
    out = subprocess.run([sys.executable, "-c", _AVX2_KERNELS.replace("WIDTH", str(width))], capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip().splitlines()


@pytest.mark.skipif(not os.path.exists("/proc/cpuinfo"), reason="reads the CPU's flags from /proc/cpuinfo")
def test_set_llvm_target_compiles_mitsubas_kernels_for_an_avx2_cpu():
    # What `rtbench speed --isa avx2` pairs our AVX2 build with: Mitsuba's kernels as a CPU with
    # AVX2 only gets them (8 lanes, no AVX-512), on this CPU, in a fresh process (the target
    # holds for the process). The image is Mitsuba's own at either width: the same random
    # numbers, its mean the same to single-precision rounding. After a kernel has run the call
    # is refused: a scene loaded at 16 lanes renders black at 8.
    if "avx2" not in cpu_flags():
        pytest.skip("the CPU has no AVX2")
    try:
        select_variant("llvm_ad_rgb")
    except (RuntimeError, ValueError) as e:
        pytest.skip(f"llvm_ad_rgb does not run here: {e}")
    *_, native, late = _kernels(0)
    bad_width, bad_cpu, target, narrow, late_too = _kernels(8)
    assert bad_width == "refused: vector_width must be 4, 8 or 16, got 3"
    assert bad_cpu == "refused: cpu must name an LLVM CPU, e.g. 'haswell'"
    before, after, cpu, avx512, reported = target.split()
    assert before in ("8", "16") and (after, cpu, avx512, reported) == ("8", "haswell", "False", "True")
    assert float(native) > 0.1 and float(narrow) == pytest.approx(float(native), rel=1e-5)
    for line in (late, late_too):
        assert line.startswith("refused: an LLVM target must be set before this process runs any Dr.Jit kernel")


def test_set_llvm_target_needs_the_llvm_variant():
    select_variant("scalar_rgb")
    with pytest.raises(RuntimeError, match="an LLVM target needs an llvm variant active, not 'scalar_rgb'"):
        set_llvm_target("haswell", "+avx2", 8)


def test_llvm_target_is_none_without_an_llvm_backend():
    # A libLLVM that cannot load leaves Dr.Jit's LLVM backend off: no target to report
    # (a fresh process, since Dr.Jit reads DRJIT_LIBLLVM_PATH once, when it is imported).
    code = ("import drjit; from mitsuba_scenes.variants import llvm_target; print(llvm_target())")
    env = dict(os.environ, DRJIT_LIBLLVM_PATH="/nonexistent/libLLVM.so")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "None"
