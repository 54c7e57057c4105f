"""Pixel reconstruction filters as Mitsuba defines them: weights, splats, agreement with Mitsuba,
and an honest per-pixel variance for a filtered image (a ratio of correlated sums)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import get_scene, render_mitsuba

from mitsuba_stats import compare


def _filtered(name, f, size=24):
    s = get_scene(name, width=size, height=size)
    return dataclasses.replace(s, camera=dataclasses.replace(s.camera, filter=f))


def test_filter_values_and_validation():
    assert rt.Filter().kind == "box" and rt.Filter().radius == 0.5
    assert rt.Filter("tent").radius == 1.0 and rt.Filter("gaussian", stddev=0.25).radius == 1.0
    for bad in (dict(kind="lanczos"), dict(kind="gaussian", radius=2.0), dict(kind="tent", stddev=1.0),
                dict(kind="tent", radius=0.0), dict(kind="box", radius=1.0), dict(kind="gaussian", stddev=-1)):
        with pytest.raises(ValueError):
            rt.Filter(**bad)
    with pytest.raises(ValueError, match="Camera.filter"):
        rt.Camera(lookfrom=(0, 0, -1), lookat=(0, 0, 0), filter="gaussian")


def test_mitsubas_filter_weights():
    """Our weights are Mitsuba's (its llvm variants evaluate the filter; the Gaussian on the
    CPU through a polynomial of the exponential, within 5e-4 of it)."""
    import mitsuba as mi

    from mitsuba_scenes.variants import import_mitsuba

    import_mitsuba()
    xs = [0.0, 0.3, 0.5, 0.9, 1.2, 1.9]
    g = mi.load_dict({"type": "gaussian"})
    t = mi.load_dict({"type": "tent", "radius": 1.5})
    for x in xs:
        gauss = math.exp(-x * x / 0.5) - math.exp(-8.0)
        assert abs(float(np.ravel(g.eval(x))[0]) - gauss) < 5e-4
        assert abs(float(np.ravel(t.eval(x))[0]) - max(0.0, 1 - x / 1.5)) < 1e-6


def test_box_scenes_keep_their_images_and_hashes():
    s = get_scene("cornell_box", width=16, height=16)
    boxed = dataclasses.replace(s, camera=dataclasses.replace(s.camera, filter=rt.Filter("box")))
    assert boxed.content_hash() == s.content_hash()
    a = rt.render(s, spp=8, strategy="mis", seed=3, threads=2)
    b = rt.render(boxed, spp=8, strategy="mis", seed=3, threads=2)
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance)
    assert _filtered("cornell_box", rt.Filter("tent"), 16).content_hash() != s.content_hash()


def test_a_filter_spreads_a_sample_over_its_neighbours():
    """A camera looking at a bright quad that covers only the left half of the image: with a
    box filter the right half is black, with a tent of radius 1 the first column right of the
    edge receives light, and no pixel two beyond it does."""
    cam = rt.Camera(lookfrom=(0, 0, -5), lookat=(0, 0, 0), vfov=40, width=8, height=8)
    half = rt.Quad((-10, -10, 0), (0, 20, 0), (10, 0, 0), rt.DiffuseLight(1.0))  # x < 0, facing -z
    for f, lit in ((rt.Filter("box"), 0), (rt.Filter("tent"), 1), (rt.Filter("tent", radius=2.0), 2)):
        scene = rt.Scene(camera=dataclasses.replace(cam, filter=f), shapes=[half], max_depth=1)
        img = rt.render(scene, spp=64, strategy="mis", seed=0, threads=1).mean[..., 0]
        # the image's x axis points to -x of the world here: the light fills columns 4..7
        col = img.mean(axis=0)
        assert np.all(col[4:] > 0.4)
        assert np.all(col[:4 - lit] == 0.0) and (lit == 0 or np.all(col[4 - lit:4] > 0))


@pytest.mark.parametrize("f", [rt.Filter("tent"), rt.Filter("gaussian"), rt.Filter("tent", radius=1.7)],
                         ids=["tent", "gaussian", "wide_tent"])
def test_filtered_image_agrees_with_mitsuba(f):
    scene = _filtered("cornell_box", f)
    ours = rt.render(scene, spp=256, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(scene, spp=256, seed=1, batches=16, threads=2)
    res = compare(ours.mean, ours.variance, 256, mit.mean, mit.variance, 256)
    assert res.ok, res.message
    # and the same Mitsuba render differs from our box-filtered image: the test can fail
    boxed = rt.render(get_scene("cornell_box", width=24, height=24), spp=256, strategy="mis", seed=1, threads=2)
    assert not compare(boxed.mean, boxed.variance, 256, mit.mean, mit.variance, 256).ok


def test_filtered_variance_is_honest():
    """The per-sample variance a filtered render reports (from its 16 batches) matches the
    spread of its images over independent seeds: the mean over pixels of (between-seed
    variance x spp) / (reported variance) is 1 within its sampling error. With 24 seeds the
    between-seed variance of a pixel has relative error sqrt(2/23); over 576 x 3 pixel-channels
    (correlated by the filter) the mean of the ratios has an error well under 0.1: the bound
    0.8-1.25 is about 5 of those errors."""
    scene = _filtered("cornell_box", rt.Filter("gaussian"))
    renders = [rt.render(scene, spp=64, strategy="mis", seed=100 + k, threads=2) for k in range(24)]
    means = np.stack([r.mean for r in renders]).astype(np.float64)
    between = means.var(axis=0, ddof=1) * 64
    reported = np.mean([r.variance for r in renders], axis=0)
    ok = reported > 1e-6
    ratio = float(np.mean(between[ok] / reported[ok]))
    assert 0.8 < ratio < 1.25, ratio


@pytest.mark.parametrize("kind", ["gaussian", "tent"])
def test_filtered_pixel_statistics_from_the_samples(kind):
    """The filtered pixels' variance computed from the samples drawn inside each pixel
    (benchmarks.gate.filtered) against the spread of the filtered images over 40 seeds: the
    median ratio over pixel-channels near 1 (measured 1.09 for both filters; above 1 where a
    pixel straddles an emitter's edge, whose samples' weights and radiance are not
    independent as assumed), and a 4x4 tile's sum has about the variance of its pixels'
    samples (measured 1.26-1.32: more than the truth by the samples near the tile's edges,
    against 0.45-0.61 for the sum of the filtered pixels' variances, which ignores that they
    share samples). With 40 seeds a pixel's between-seed variance has relative error 0.23; the
    medians over 768 pixel-channels and 16 tiles x 3 are far tighter than the bounds."""
    from benchmarks.gate.filtered import filter_weights, filtered_moments

    scene = _filtered("cornell_box", rt.Filter(kind), 16)
    imgs = np.stack([rt.render(scene, spp=64, strategy="mis", seed=100 + k, threads=2).mean
                     for k in range(40)]).astype(np.float64)
    hi = rt.render(scene, spp=16384, strategy="mis", seed=7, threads=2)
    m2, _, _ = filtered_moments(filter_weights(scene.camera.filter), mean=hi.pixel_samples.mean,
                                variance=hi.pixel_samples.variance, filtered_mean=hi.mean)
    between = imgs.var(axis=0, ddof=1)
    ok = between > 1e-8
    assert 0.95 < np.median(m2[ok] / 64 / between[ok]) < 1.3

    def tiles(a):
        return a.reshape(*a.shape[:-3], 4, 4, 4, 4, 3).sum(axis=(-4, -2))

    sums = np.median(tiles(hi.pixel_samples.variance / 64.0) / tiles(imgs).var(axis=0, ddof=1))
    assert 1.0 < sums < 1.6
    assert np.median(tiles(m2 / 64) / tiles(imgs).var(axis=0, ddof=1)) < 0.75  # why the sums use the samples'


def test_the_gate_judges_filtered_renders():
    """The gate on a Gaussian-filtered scene: an unbiased render passes and one 2% too bright
    fails (the false-alarm rate, 0 in 120 comparisons, is measured by ``rtbench gate
    --calibrate``: benchmarks/STATISTICS.md)."""
    from benchmarks.gate import compare as gate_compare
    from benchmarks.gate.filtered import filter_weights

    scene = _filtered("cornell_box", rt.Filter("gaussian"), 24)
    mit = render_mitsuba(scene, spp=4096, seed=3, batches=16, threads=2)
    out = rt.render(scene, spp=1024, strategy="mis", seed=5, threads=2)
    kw = dict(pixel_samples=(out.pixel_samples.mean, out.pixel_samples.variance),
              filter_weights=filter_weights(scene.camera.filter))
    assert gate_compare(out.mean, out.variance, 1024, mit.mean, mit.variance, 4096, **kw).verdict == "pass"
    assert gate_compare(out.mean * 1.02, out.variance, 1024, mit.mean, mit.variance, 4096, **kw).verdict == "fail"
    fw = filter_weights(scene.camera.filter)
    assert fw.radius == 3 and abs(float(fw.F[0].sum()) - 1.0) < 1e-9
    with pytest.raises(ValueError, match="box"):
        filter_weights(rt.Filter())


def test_filtered_renders_refuse_moments_and_tail_references_are_the_samples(tmp_path):
    from benchmarks.tails import tail_reference

    scene = _filtered("cornell_box", rt.Filter("tent"), 8)
    with pytest.raises(ValueError, match="box filter for them"):
        rt.render(scene, spp=4, moments=True)
    tails = tail_reference(scene, strategy="mis", spp=16, cache=tmp_path)
    box = tail_reference(_filtered("cornell_box", rt.Filter(), 8), strategy="mis", spp=16, cache=tmp_path)
    assert np.array_equal(tails.moments.m2, box.moments.m2)  # the same samples, one cache entry


def test_filters_round_trip_through_mitsuba_xml(tmp_path):
    from mitsuba_scenes import from_mitsuba, to_xml

    for f in (rt.Filter("tent", radius=1.25), rt.Filter("gaussian", stddev=0.4), rt.Filter()):
        scene = _filtered("cornell_box", f, 8)
        back = from_mitsuba(to_xml(scene, tmp_path / f"{f.kind}.xml")).camera.filter
        # Mitsuba's parser keeps floats in single precision
        assert back.kind == f.kind and back.radius == pytest.approx(f.radius, rel=1e-7)
