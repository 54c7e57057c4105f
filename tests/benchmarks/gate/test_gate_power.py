"""False-alarm rate and power of the regression gate on real renders (issue 7).

References
    The gate's own: cached Mitsuba renders (``benchmarks.gate.gate_reference``), so
    these numbers are what ``rtbench gate`` reports, and Mitsuba's per-pixel rule, which
    is defined against a Mitsuba reference, sees the same data. The power test uses the
    gate's default references (32x32, 16384 spp) from the shared cache
    (``$RTBENCH_CACHE`` or ``~/.cache/rtbench``): CI's gate run after the tests reuses
    them. The false-alarm tests use small images and their own cache.

False-positive bounds (fixed seeds make each test deterministic; the bound is the chance
that a gate *exactly at* its nominal level would fail the test for an arbitrary choice
of seeds; the gate is conservative, so the real chance is lower)
    * ``test_false_alarms_quick``: 12 seeds x 8 scenes; at most 1 failed run
      (P(Bin(12, 0.01) >= 2) = 0.6%) and at most 4 comparisons with p < 0.01 unadjusted
      among 96 (P(Bin(96, 0.01) >= 5) = 0.3%).
    * ``test_false_alarms_100_seeds`` (slow): at least 99 of 100 runs pass
      (P(Bin(100, 0.01) >= 2) = 26% at the nominal level; 1.7% at a true rate of 0.2%)
      and at most 16 comparisons with p < 0.01 among 800 (P(Bin(800, 0.01) >= 17) = 0.2%).
    * ``test_power_at_default_spp``: the gate must catch each injection at the seed used;
      an injection the gate catches with probability 0.95 would fail this test 5% of the
      time for an arbitrary seed; the measured rates are in ``benchmarks.gate.suite``.
"""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.constants import GATE_ALPHA
from benchmarks.gate import DEFAULT_SPP, INJECTIONS, QUICK_SUITE_COMPARISONS, power_row, run_gate

THREADS = 2
CASE_ALPHA = GATE_ALPHA / QUICK_SUITE_COMPARISONS


def _false_alarms(seeds, *, width, spp, ref_spp, cache):
    runs, small_p = [], []
    for seed in seeds:
        report = run_gate(None, spp=spp, width=width, ref_spp=ref_spp, seed=seed, threads=THREADS, cache=cache)
        assert report.case_alpha == pytest.approx(GATE_ALPHA / 8)
        runs.append(report)
        small_p += [(seed, c.scene, c.result.p_value) for c in report.cases if c.result.p_value < 0.01]
    failed = [(r.cases[0].seed, [c.message() for c in r.failures]) for r in runs if not r.passed]
    return runs, failed, small_p


def test_false_alarms_quick(tmp_path_factory):
    """Unbiased ``mis`` renders of the whole quick suite, 12 seeds, 16x16 at 256 spp."""
    cache = tmp_path_factory.mktemp("fa-cache")
    runs, failed, small_p = _false_alarms(range(100, 112), width=16, spp=256, ref_spp=2048, cache=cache)
    n_cmp = sum(len(r.cases) for r in runs)
    print(f"\nquick false alarms: {len(failed)} of {len(runs)} runs failed; {len(small_p)} of {n_cmp} "
          f"comparisons with p < 0.01: {small_p}")
    assert n_cmp == 96
    assert len(failed) <= 1, failed
    assert len(small_p) <= 4, small_p


@pytest.mark.slow
def test_false_alarms_100_seeds(tmp_path_factory):
    """The gate at its default spp passes unbiased renders in at least 99 of 100 seeds
    (whole quick suite at 16x16, references at the default 16384 spp)."""
    cache = tmp_path_factory.mktemp("fa100-cache")
    runs, failed, small_p = _false_alarms(range(1000, 1100), width=16, spp=DEFAULT_SPP, ref_spp=16384, cache=cache)
    n_cmp = sum(len(r.cases) for r in runs)
    print(f"\n100-seed false alarms: {len(failed)} of {len(runs)} runs failed {failed}; {len(small_p)} of {n_cmp} "
          f"comparisons with p < 0.01: {small_p}")
    assert len(runs) - len(failed) >= 99, failed
    assert len(small_p) <= 16, small_p


@pytest.fixture(scope="module")
def power_rows():
    """Each injection once at the gate's default spp, seed 1; Mitsuba references from the shared cache."""
    rows = [power_row(name, seed=1, spp=DEFAULT_SPP, threads=THREADS) for name in INJECTIONS]
    for r in rows:
        print(f"\n{r.injection} ({r.scene}): ours p = {r.p_value:.2g} ({', '.join(r.failed_levels) or '-'}), "
              f"bias {r.relative_bias:+.2%} +- {r.relative_bias_se:.2%}; Mitsuba's rule "
              f"{'caught' if r.mitsuba_caught else 'passed'} ({r.mitsuba_failed_fraction:.2%} failed)")
    return {r.injection: r for r in rows}


@pytest.mark.parametrize("name", [n for n in INJECTIONS if n != "Schlick Fresnel"])
def test_power_at_default_spp(power_rows, name):
    row = power_rows[name]
    assert row.spp == DEFAULT_SPP
    assert row.caught and row.p_value < CASE_ALPHA, (name, row.p_value, row.failed_levels)
    # and the estimated bias points the right way where its sign is known
    sign = {"scale 0.99": -1, "red wall albedo +3%": +1, "light strategy": -1}.get(name)
    if sign is not None:
        assert np.sign(row.relative_bias) == sign, row.relative_bias


def test_schlick_recorded_at_default_spp(power_rows):
    """Schlick on ``cornell_glass`` brightens a few glass pixels by 5-13% and moves the image sum
    by under 0.1% (+0.01% against a 65536-spp reference, seeds 1-10 at 65536 spp). At the default
    4096 spp the gate caught it in 0 of 20 seeds (seeds 1-20, smallest p 0.0028), so whether it
    catches it is recorded here, not asserted; see ``test_schlick_caught_at_65536_spp``. What is
    asserted: the row's bias estimate agrees with +0.2% (within 3 of its standard errors: a 0.3%
    chance to fail for an arbitrary seed), the default 16384-spp reference's own offset (the
    same renders read +0.17% against it), and Mitsuba's rule "catches" it, only because it fails
    the unbiased ``cornell_glass`` render too (``test_mitsuba_rule_false_alarm_on_unbiased_glass``)."""
    row = power_rows["Schlick Fresnel"]
    assert row.spp == DEFAULT_SPP and row.scene == "cornell_glass" and 0.0 <= row.p_value <= 1.0
    assert row.relative_bias_se > 0 and abs(row.relative_bias - 0.002) < 3 * row.relative_bias_se, row
    assert row.mitsuba_caught and row.mitsuba_failed_fraction > 0, row


@pytest.mark.slow
def test_schlick_caught_at_65536_spp():
    """Schlick against the default 16384-spp reference and tail reference, seeds 1-20: the gate
    caught it in 0 of 20 at 4096 spp, 5 of 20 at 16384 (median p 0.0045), 11 of 20 at 32768
    (median p 0.00098) and 20 of 20 at 65536 (p at most 0.001; seed 1: 2.5e-6); the assertion
    needs p < 1.25e-3. The evidence is a few pixels inside the caustic, which the pixel level
    judges with their 3x3 neighbourhood's mean variance where it is larger
    (``benchmarks/STATISTICS.md``, Known limits)."""
    row = power_row("Schlick Fresnel", seed=1, spp=65536, threads=THREADS)
    assert row.caught and row.p_value < CASE_ALPHA, row


def test_mitsuba_rule_false_alarm_on_unbiased_glass():
    """Mitsuba's per-pixel rule on an *unbiased* ``mis`` render of ``cornell_glass`` (the
    control of the Schlick row): it ignores the test render's own variance and the
    reference's noise, and fails (26-67 failing pixel-channels in 12 of 12 seeds measured
    at 1024 and 4096 spp); our gate passes the same render."""
    from benchmarks.gate import compare_render, gate_reference, gate_scene, mitsuba_rule
    import reference_tracer as rt

    scene = gate_scene("cornell_glass")
    ref = gate_reference("cornell_glass", scene, threads=THREADS)
    out = rt.render(scene, spp=DEFAULT_SPP, strategy="mis", seed=1, threads=THREADS)
    assert compare_render(out.mean, out.variance, DEFAULT_SPP, ref, alpha=CASE_ALPHA).passed
    assert not mitsuba_rule(out.mean, ref.mean, ref.variance, DEFAULT_SPP).passed


@pytest.mark.parametrize("name", ["Schlick Fresnel", "scale 0.99"])
def test_power_row_judges_with_the_injected_estimators_tails(monkeypatch, name):
    """A build with the bug renders its own tail reference: power_row asks for the tails of the
    injected scene, and scales their moments with a scaled image (m_k by scale^k, max by scale)."""
    from dataclasses import dataclass

    import benchmarks.gate.power as power
    from reference_tracer.estimate import SampleMoments

    @dataclass
    class Tails:  # what compare_render reads of a tail reference
        moments: SampleMoments

    ones = np.ones((8, 8, 3))
    seen = {}

    def tails(scene, strategy, **_):
        seen["scene"] = scene
        return Tails(SampleMoments(n=4, m2=ones, m3=2 * ones, m4=3 * ones, max=4 * ones))

    judge, reference = power.compare_render, power.gate_reference

    def compare(mean, variance, spp, reference, *, alpha, tails):
        seen["moments"] = tails.moments
        return judge(mean, variance, spp, reference, alpha=alpha, tails=None)

    monkeypatch.setattr(power, "gate_tails", tails)
    monkeypatch.setattr(power, "compare_render", compare)
    monkeypatch.setattr(power, "gate_reference", lambda scene_name, base, **kw: reference(
        scene_name, base, ref_spp=16, threads=kw["threads"], cache=kw["cache"]))
    power.power_row(name, spp=4, width=8, threads=THREADS)
    scene_name, _, scale, edit = INJECTIONS[name]
    injected = power.injected_scene(power.gate_scene(scene_name, width=8), edit)
    assert seen["scene"].content_hash() == injected.content_hash()
    m = seen["moments"]
    for field, k, value in (("m2", 2, 1.0), ("m3", 3, 2.0), ("m4", 4, 3.0), ("max", 1, 4.0)):
        np.testing.assert_allclose(getattr(m, field), value * scale**k, rtol=1e-12, err_msg=field)
