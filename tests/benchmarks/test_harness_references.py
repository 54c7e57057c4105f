"""Reference cache: a hit renders nothing; corrupt or partial entries are detected and re-rendered."""
from __future__ import annotations

import json

import numpy as np
import pytest

import mitsuba_scenes
from benchmarks.references import cache_dir, load_reference, reference, reference_key
from benchmarks.scenes import scene_at
from harness_util import rtbench

SPP = 64


@pytest.fixture
def scene():
    return scene_at("cornell_box", 8, 8)


@pytest.fixture
def cache(tmp_path):
    return tmp_path / "cache"


def _forbid_rendering(monkeypatch):
    def boom(*a, **k):
        raise AssertionError("a cache hit must not render")

    monkeypatch.setattr(mitsuba_scenes, "render_mitsuba", boom)


def test_miss_then_hit_renders_once(scene, cache, monkeypatch):
    first = reference(scene, spp=SPP, cache=cache)
    assert not first.cached
    assert first.mean.shape == first.variance.shape == (8, 8, 3)
    assert np.all(first.variance >= 0) and first.variance.mean() > 0
    assert first.path.exists() and first.variance_path.exists()
    _forbid_rendering(monkeypatch)
    hit = reference(scene, spp=SPP, cache=cache)
    assert hit.cached and hit.key == first.key
    np.testing.assert_array_equal(hit.mean, first.mean)
    np.testing.assert_array_equal(hit.variance, first.variance)


def test_key_depends_on_scene_size_spp_and_seed(scene, cache):
    ref = reference(scene, spp=SPP, cache=cache)
    h = scene.content_hash()
    base = dict(mitsuba_version=ref.mitsuba_version, variant=ref.variant, spp=SPP, seed=ref.seed)
    assert reference_key(h, **base) == ref.key
    others = {reference_key(scene_at("cornell_box", 8, 9).content_hash(), **base),
              reference_key(h, **{**base, "spp": SPP * 2}), reference_key(h, **{**base, "seed": 1}),
              reference_key(h, **{**base, "variant": "scalar_rgb"}),
              reference_key(h, **{**base, "mitsuba_version": "0.0.0"})}
    assert ref.key not in others and len(others) == 5


@pytest.mark.parametrize("damage", ["truncate_mean", "flip_variance_byte", "drop_sidecar", "garbage_sidecar",
                                    "delete_variance", "sidecar_of_other_key"])
def test_corrupt_or_partial_entry_is_rerendered(scene, cache, damage):
    ref = reference(scene, spp=SPP, cache=cache)
    folder = cache_dir(cache)
    sidecar = folder / f"{ref.key}.json"
    if damage == "truncate_mean":
        data = ref.path.read_bytes()
        ref.path.write_bytes(data[: len(data) // 2])
    elif damage == "flip_variance_byte":
        data = bytearray(ref.variance_path.read_bytes())
        data[len(data) - 7] ^= 0xFF
        ref.variance_path.write_bytes(bytes(data))
    elif damage == "drop_sidecar":     # killed after the images, before the sidecar
        sidecar.unlink()
    elif damage == "garbage_sidecar":
        sidecar.write_text('{"key": ')
    elif damage == "delete_variance":
        ref.variance_path.unlink()
    elif damage == "sidecar_of_other_key":
        meta = json.loads(sidecar.read_text())
        meta["key"] = "0" * 64
        sidecar.write_text(json.dumps(meta))
    bad, why = load_reference(ref.key, shape=(8, 8), cache=cache)
    assert bad is None and why
    lines = []
    again = reference(scene, spp=SPP, cache=cache, log=lines.append)
    assert not again.cached
    if damage != "drop_sidecar":  # a missing sidecar is simply "not cached"
        assert lines and "re-rendering" in lines[0]
    # the same seed gives the same reference, and the repaired entry is a valid hit again
    np.testing.assert_array_equal(again.mean, ref.mean)
    ok, why = load_reference(ref.key, shape=(8, 8), cache=cache)
    assert ok is not None and ok.cached, why


def test_bad_arguments_raise_value_error(scene, cache):
    with pytest.raises(ValueError, match="spp"):
        reference(scene, spp=1, cache=cache)
    with pytest.raises(ValueError, match="Scene"):
        reference("cornell_box", spp=SPP, cache=cache)
    with pytest.raises(ValueError, match="seed"):
        reference(scene, spp=SPP, seed=-1, cache=cache)


def test_cli_reports_render_then_cache_hit(tmp_path):
    args = ("reference", "cornell_box", "--spp", "16", "--width", "4", "--height", "4")
    first = rtbench(*args, cache=tmp_path)
    assert "rendered in" in first.stdout
    second = rtbench(*args, "--export", tmp_path / "exp", cache=tmp_path)
    assert "cache hit" in second.stdout
    assert (tmp_path / "exp" / "cornell_box_4x4_spp16.exr").exists()
    bad = rtbench("reference", "no_such_scene", cache=tmp_path, check=False)
    assert bad.returncode == 2 and "unknown scene" in bad.stderr and "Traceback" not in bad.stderr
