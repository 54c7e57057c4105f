"""The render loop: determinism, counters, interruption, progress, image output, CLI."""
import _thread
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import get_scene


@pytest.fixture(scope="module")
def cornell64():
    return get_scene("cornell_box", width=64, height=64)


def test_cornell_box_64_has_no_nan(cornell64):
    r = rt.render(cornell64, spp=16, strategy="cosine", seed=0, threads=2)
    assert r.mean.shape == (64, 64, 3) and r.mean.dtype == np.float32
    assert r.variance.shape == (64, 64, 3)
    assert np.all(np.isfinite(r.mean)) and np.all(np.isfinite(r.variance))
    assert r.nonfinite_samples == 0
    assert r.rays >= 64 * 64 * 16
    assert np.all(r.variance >= 0)
    # The light is visible near the top centre; the rest of the room is lit and finite.
    assert r.mean.max() >= 15.0 - 1e-6
    assert r.mean.mean() > 0.05


@pytest.mark.parametrize("strategy", rt.STRATEGIES)
def test_image_is_bit_identical_whatever_the_thread_count(cornell64, strategy):
    small = cornell64.with_camera_size(24, 20)
    images = [rt.render(small, spp=4, strategy=strategy, seed=7, threads=t) for t in (1, 2, 3)]
    for r in images[1:]:
        assert np.array_equal(r.mean, images[0].mean)
        assert np.array_equal(r.variance, images[0].variance)
        assert r.rays == images[0].rays


def test_more_threads_than_work(cornell64):
    """Threads beyond the work (a render's tiles, a query's chunks of rays) are not started:
    100,000 of them once aborted the process when the system refused one (SIGABRT)."""
    small = cornell64.with_camera_size(8, 8)
    one = rt.render(small, spp=2, strategy="mis", seed=3, threads=1)
    many = rt.render(small, spp=2, strategy="mis", seed=3, threads=100_000)
    assert np.array_equal(many.mean, one.mean) and many.threads == 100_000
    from reference_tracer.probe import core_scene

    rng = np.random.default_rng(0)
    origins, directions = np.zeros((100, 3)) + (278.0, 273.0, -800.0), rng.normal(size=(100, 3)) + (0, 0, 3)
    scene = core_scene(small)
    hits = [scene.intersect(origins, directions, threads=t) for t in (1, 100_000)]
    assert np.array_equal(hits[0]["t"], hits[1]["t"]) and np.array_equal(hits[0]["prim"], hits[1]["prim"])


_REFUSED_THREADS = """
import resource, numpy as np
import reference_tracer as rt
from mitsuba_scenes import get_scene
scene = get_scene("cornell_box", width=1024, height=1024)  # 4096 tiles of 16x16
before = rt.render(scene, spp=1, seed=1, threads=2).mean
vm = int(open("/proc/self/statm").read().split()[0]) * resource.getpagesize()
resource.setrlimit(resource.RLIMIT_AS, (vm + (1 << 30), vm + (1 << 30)))  # stacks for some 100 threads
print("same" if np.array_equal(rt.render(scene, spp=1, seed=1, threads=4096).mean, before) else "differs")
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS and /proc/self/statm are Linux's")
def test_threads_the_system_refuses():
    """Where the system refuses some of the threads asked for (here: too little address space
    for their stacks), those started render the whole image: once std::terminate (SIGABRT)."""
    done = subprocess.run([sys.executable, "-c", _REFUSED_THREADS], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["same"]


def test_seeds_give_independent_images(cornell64):
    small = cornell64.with_camera_size(16, 16)
    a = rt.render(small, spp=4, strategy="mis", seed=1).mean
    b = rt.render(small, spp=4, strategy="mis", seed=2).mean
    assert not np.array_equal(a, b)


def test_variance_is_per_sample(cornell64):
    """The per-sample variance times 1/spp predicts the spread of the mean over seeds."""
    small = cornell64.with_camera_size(8, 8)
    spp, k = 16, 40
    means = np.stack([rt.render(small, spp=spp, strategy="mixture", seed=s).mean for s in range(k)])
    per_sample = np.mean([rt.render(small, spp=spp * 8, strategy="mixture", seed=1000 + s).variance for s in range(4)], axis=0)
    predicted = per_sample.mean() / spp
    observed = means.var(axis=0, ddof=1).mean()
    # Averaged over 192 pixel-channels and 40 seeds, the two agree to well within 30%.
    assert 0.7 < observed / predicted < 1.3


def test_progress_callback_reaches_total(cornell64):
    calls = []
    rt.render(cornell64.with_camera_size(32, 32), spp=8, progress=lambda d, t: calls.append((d, t)))
    assert calls and calls[-1] == (32 * 32, 32 * 32)
    assert all(d <= t for d, t in calls)


def test_progress_callback_error_stops_render(cornell64):
    def boom(done, total):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        rt.render(cornell64.with_camera_size(256, 256), spp=256, progress=boom)


def test_ctrl_c_stops_render_promptly(cornell64):
    """Ctrl-C during a render raises KeyboardInterrupt at the render's next poll (the core
    polls for signals between its progress reports): once the interrupt is sent, no further
    progress report starts, so the render stopped within one poll's work, long before the
    end of its minutes of work. Counted, not timed."""
    big = cornell64.with_camera_size(512, 512)  # minutes of work at 512 spp
    calls, sent = [], threading.Event()

    def interrupt():
        _thread.interrupt_main()  # as Ctrl-C: a SIGINT for the main thread
        sent.set()

    def progress(done, total):
        calls.append((done, total, sent.is_set()))
        if len(calls) == 1:  # the render is under way: interrupt it from another thread
            threading.Thread(target=interrupt).start()

    # Python's own SIGINT handler, whatever an earlier test or extension left installed
    # (interrupt_main does nothing while SIGINT is ignored)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    try:
        with pytest.raises(KeyboardInterrupt):
            rt.render(big, spp=512, strategy="mis", threads=2, progress=progress)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert sent.is_set() and calls, calls
    assert not any(after for _, _, after in calls), calls   # no poll went on after the interrupt
    assert all(done < total for done, total, _ in calls), calls  # interrupted well before the end


def test_write_exr_and_png_round_trip(tmp_path):
    img = np.random.default_rng(0).uniform(0, 4, size=(5, 7, 3)).astype(np.float32)
    rt.write_exr(tmp_path / "a.exr", img)
    np.testing.assert_array_equal(rt.read_exr(tmp_path / "a.exr"), img)
    from PIL import Image

    rt.write_png(tmp_path / "a.png", np.full((2, 3, 3), 0.5), exposure=0.0)
    px = np.asarray(Image.open(tmp_path / "a.png"))
    assert px.shape == (2, 3, 3)
    # sRGB transfer (not gamma 2.0 or 2.2): 0.5 linear -> 0.7354 -> 188.
    assert np.all(px == 188)
    rt.write_png(tmp_path / "b.png", np.full((2, 3, 3), 0.25), exposure=1.0)
    assert np.all(np.asarray(Image.open(tmp_path / "b.png")) == 188)
    with pytest.raises(ValueError, match="write_png"):
        rt.write_png(tmp_path / "c.png", np.zeros((2, 3, 5)))


def test_cli_render_writes_exr_and_png(tmp_path):
    cmd = [sys.executable, "-m", "benchmarks.cli", "render", "cornell_box", "--width", "16", "--spp", "2",
           "--strategy", "mixture", "--out", str(tmp_path)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "0 NaN/Inf samples" in proc.stdout
    img = rt.read_exr(tmp_path / "cornell_box_16x16_mixture_spp2_seed0.exr")
    assert img.shape == (16, 16, 3)
    assert (tmp_path / "cornell_box_16x16_mixture_spp2_seed0.png").stat().st_size > 0


def test_cli_render_bad_input_is_one_clear_line(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "benchmarks.cli", "render", "no_such_scene"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "unknown scene 'no_such_scene'" in proc.stderr
    assert "Traceback" not in proc.stderr
