"""One routine of the catalogue (:class:`Routine`), and the runner behind ``rtbench chi2``
(:func:`run_routine`): its chi-square test and the checks beside it (README.md here, "Checks
beside the distribution"), with their outcome (:class:`Row`)."""
from __future__ import annotations

import math
import time
import zlib
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..constants import LUMINANCE_WEIGHTS

from .pearson import (DEFAULT_ALPHA, DEFAULT_N, DEFAULT_RESOLUTION, Chi2Result, Grid, chi2_test, discrete_test,
                      excess_p_value, integrate, sidak)
from .probes import BsdfProbe, LightProbe, refract_expected

__all__ = ["Routine", "Row", "run_routine"]

# Relative tolerance of the deterministic identities (weight = eval / pdf, the sampler's pdf
# = pdf(), mirror and Snell directions): the same double-precision routines on both sides.
_RTOL = 1e-9
# Samples per call of a probe in the checks beside the chi-square test.
_CHUNK = 1 << 20
# Relative tolerance of a light sample's pdf against light_pdf in its direction: the
# sampled point and the ray's hit point differ by the rounding of a ray intersection.
_LIGHT_RTOL = 1e-6
_LUM = np.asarray(LUMINANCE_WEIGHTS)


@dataclass(frozen=True)
class Routine:
    """One routine with one set of parameters. ``make()`` builds its probe lazily."""

    name: str
    params: tuple              # ((key, value), ...), shown in tables
    kind: str                  # 'warp', 'bsdf', 'mixed' (a Dirac lobe beside a density), 'lobes' or 'light'
    make: Callable[[], dict] = field(compare=False, repr=False)   # -> the probe and its test settings

    @property
    def param_text(self) -> str:
        return ", ".join(f"{k}={v}" for k, v in self.params)

    @property
    def label(self) -> str:
        return f"{self.name}[{self.param_text}]" if self.params else self.name

    def seed(self, base: int) -> int:
        """A seed of its own per routine (stable whatever else is run), from ``base``."""
        return (zlib.crc32(self.label.encode()) + 7919 * int(base)) % 2**32


@dataclass
class Row:
    """The outcome of one routine's tests: ``verdict`` over all its checks."""

    routine: str
    params: str
    n: int
    p_value: float
    verdict: str
    seconds: float
    message: str = ""
    checks: dict = field(default_factory=dict)
    result: Chi2Result | None = field(default=None, repr=False)

    @property
    def passed(self) -> bool:
        return self.verdict == "pass"

    def to_json(self) -> dict:
        stats = ("alpha", "statistic", "dof", "n_valid", "mass", "mass_p_value", "pooled_in", "pooled_out")
        return {"routine": self.routine, "params": self.params, "n": self.n, "p_value": self.p_value,
                "verdict": self.verdict, "seconds": round(self.seconds, 3), "message": self.message,
                **{k: getattr(self.result, k, None) for k in stats}, "checks": self.checks}


def _chunks(n: int, seed: int, dims: int = 3):
    """The uniform numbers of ``n`` samples, in chunks (bounded memory at any n)."""
    rng = np.random.default_rng(seed)
    for start in range(0, n, _CHUNK):
        yield rng.random((min(_CHUNK, n - start), dims))


def _weight_stats(w_sum: float, w_sq: float, n: int) -> tuple:
    """Mean and standard error of ``n`` sample weights from their sum and sum of squares."""
    mean = w_sum / n
    return mean, math.sqrt(max(w_sq / n - mean * mean, 0.0) / max(n - 1, 1))


def _mismatches(s: dict, rows, probe: BsdfProbe) -> tuple:
    """Samples ``rows`` whose weight is not eval / pdf, and whose pdf is not pdf()."""
    ev = probe.eval_pdf(s["wi"][rows])
    ratio = ev["value"] / ev["pdf"][:, None]
    return (int((~np.isclose(s["weight"][rows], ratio, rtol=_RTOL, atol=0)).any(axis=1).sum()),
            int((~np.isclose(s["pdf"][rows], ev["pdf"], rtol=_RTOL, atol=0)).sum()))


def _albedo_check(probe: BsdfProbe, grid: Grid, n: int, mean: float, se: float, level: float, *,
                  offset: float = 0.0, key: str = "expected") -> dict:
    """The integral of f cos (plus ``offset``, a Dirac lobe's share; reported as ``key``) against
    the mean weight."""
    integ, err, _, bad = integrate(lambda d: probe.eval_pdf(d)["value"] @ _LUM, grid, n=n)
    albedo = offset + float(integ.sum())
    p = excess_p_value(albedo - mean, err + _RTOL * abs(albedo), se)
    return {"ok": p >= level and bad == 0, key: albedo, "mean_weight": mean, "se": se,
            "integration_error": err, "p_value": p}


def _bsdf_checks(probe: BsdfProbe, grid: Grid, n: int, seed: int, level: float) -> dict:
    """weight = eval / pdf and pdf = pdf() at every sample; albedo = mean weight."""
    bad_weight = bad_pdf = valid_count = 0
    w_sum = w_sq = 0.0
    for u in _chunks(n, seed):
        s = probe.sample_full(u)
        valid = s["valid"].astype(bool)
        bw, bp = _mismatches(s, valid, probe)
        bad_weight, bad_pdf, valid_count = bad_weight + bw, bad_pdf + bp, valid_count + int(valid.sum())
        wl = s["weight"][valid] @ _LUM                       # failed samples weigh 0
        w_sum, w_sq = w_sum + float(wl.sum()), w_sq + float((wl * wl).sum())
    return {
        "weight_is_eval_over_pdf": {"ok": bad_weight == 0, "mismatches": bad_weight, "samples": valid_count},
        "sample_pdf_is_pdf": {"ok": bad_pdf == 0, "mismatches": bad_pdf},
        "albedo": _albedo_check(probe, grid, n, *_weight_stats(w_sum, w_sq, n), level, key="integral_f_cos"),
    }


def _mixed_checks(spec: dict, grid: Grid, n: int, seed: int, level: float):
    """The smooth plastic's samples: the specular ones in the mirror direction with weight
    ks F / Ps, the diffuse ones with weight eval / pdf and pdf = pdf(); their counts against
    Ps (a discrete test at ``level``); the mean weight against ks F plus the diffuse lobe's
    albedo. Returns the discrete test's result and the checks."""
    probe: BsdfProbe = spec["probe"]
    wo, F, ks, p_specular = probe.wo, spec["F"], spec["specular"], spec["p_specular"]
    mirror = np.array([-wo[0], -wo[1], wo[2]])
    bad_dir = bad_spec = bad_weight = bad_pdf = n_spec = n_diff = 0
    w_sum = w_sq = 0.0
    for u in _chunks(n, seed):
        s = probe.sample_full(u)
        valid, delta = s["valid"].astype(bool), s["delta"].astype(bool)
        spec_rows, diff_rows = valid & delta, valid & ~delta
        bad_dir += int((~np.all(np.abs(s["wi"][spec_rows] - mirror) <= _RTOL, axis=1)).sum())
        bad_spec += int((~np.isclose(s["weight"][spec_rows], ks * (F / p_specular), rtol=_RTOL, atol=0))
                        .any(axis=1).sum())
        bw, bp = _mismatches(s, diff_rows, probe)
        bad_weight, bad_pdf = bad_weight + bw, bad_pdf + bp
        n_spec, n_diff = n_spec + int(spec_rows.sum()), n_diff + int(diff_rows.sum())
        wl = np.where(valid, s["weight"] @ _LUM, 0.0)
        w_sum, w_sq = w_sum + float(wl.sum()), w_sq + float((wl * wl).sum())
    res = discrete_test([n_spec, n - n_spec], [p_specular, 1.0 - p_specular], alpha=level)
    res.details.update(p_specular=p_specular, specular=n_spec, other=n - n_spec)
    checks = {
        "specular_is_mirror": {"ok": bad_dir == 0, "mismatches": bad_dir, "samples": n_spec},
        "specular_weight_is_ks_F_over_Ps": {"ok": bad_spec == 0, "mismatches": bad_spec},
        "diffuse_weight_is_eval_over_pdf": {"ok": bad_weight == 0, "mismatches": bad_weight, "samples": n_diff},
        "sample_pdf_is_pdf": {"ok": bad_pdf == 0, "mismatches": bad_pdf},
        "every_sample_valid": {"ok": n_spec + n_diff == n, "invalid": n - n_spec - n_diff},
        "albedo": _albedo_check(probe, grid, n, *_weight_stats(w_sum, w_sq, n), level, offset=float(ks @ _LUM) * F),
    }
    return res, checks


def _light_checks(probe: LightProbe, single: bool, n: int, seed: int, reported=None) -> dict:
    """A sample's pdf equals light_pdf in its direction (one emitter) or is at most it; with
    ``reported`` (a function of world directions), light_pdf at every sample equals it.
    Delta lights' samples have no density: :func:`_delta_checks` takes them."""
    bad = bad_all = valid_count = bad_reported = 0
    worst = 0.0
    for u in _chunks(n, seed):
        s = probe.sample_full(u)
        valid = s["valid"].astype(bool) & ~s["delta"].astype(bool)
        wi = np.ascontiguousarray(s["wi"][valid])
        pdf, pdf_all = s["pdf"][valid], s["pdf_all"][valid]
        lp = probe.core.light_pdf(np.ascontiguousarray(np.broadcast_to(probe.ref, wi.shape)), wi)
        if single:
            bad += int((~np.isclose(pdf, lp, rtol=_LIGHT_RTOL, atol=0)).sum())
            if len(lp):
                worst = max(worst, float(np.max(np.abs(pdf / np.where(lp > 0, lp, np.inf) - 1.0))))
        else:
            bad += int((pdf > lp * (1 + _LIGHT_RTOL)).sum())
        bad_all += int((~np.isclose(pdf_all, lp, rtol=_RTOL, atol=0)).sum())
        if reported is not None:
            bad_reported += int((~np.isclose(lp, reported(wi), rtol=_LIGHT_RTOL, atol=0)).sum())
        valid_count += int(valid.sum())
    checks = {"sample_pdf_matches_light_pdf": {"ok": bad == 0, "mismatches": bad, "samples": valid_count,
                                               "worst_relative": worst if single else None},
              "pdf_all_is_light_pdf": {"ok": bad_all == 0, "mismatches": bad_all}}
    if reported is not None:
        checks["light_pdf_is_mitsubas_shading_density"] = {"ok": bad_reported == 0, "mismatches": bad_reported}
    return checks


def _delta_checks(probe: LightProbe, expected: list, n: int, seed: int, alpha: float):
    """The delta lights' samples: each points along one expected direction ``wi`` (toward a
    point or spot light from the reference point, against a directional light's travel),
    with the expected radiance (intensity / dist^2, times a spot's falloff; a directional
    light's irradiance) and pdf (its selection's probability, from the powers of
    ``lights.h``'s rule computed here independently); their counts against those
    probabilities (a discrete test at ``alpha``, the other samples one outcome). Returns the
    test's result and the checks."""
    names = [e[0] for e in expected]
    wis = np.array([e[1] for e in expected], dtype=np.float64)
    counts = np.zeros(len(expected) + 1, dtype=np.int64)
    bad_dir = bad_value = bad_pdf = unmatched = 0
    for u in _chunks(n, seed):
        s = probe.sample_full(u)
        valid, delta = s["valid"].astype(bool), s["delta"].astype(bool)
        rows = valid & delta
        wi, pdf, radiance = s["wi"][rows], s["pdf"][rows], s["radiance"][rows]
        which = np.argmax(wi @ wis.T, axis=1) if len(wi) else np.zeros(0, dtype=int)
        for k, (_, w, value, pmf) in enumerate(expected):
            m = which == k
            close = np.all(np.abs(wi[m] - np.asarray(w)) <= 1e-12, axis=1)
            bad_dir += int((~close).sum())
            bad_value += int((~np.isclose(radiance[m], np.asarray(value, dtype=float), rtol=_RTOL, atol=0))
                             .any(axis=1).sum())
            bad_pdf += int((~np.isclose(pdf[m], pmf, rtol=_RTOL, atol=0)).sum())
            counts[k] += int(m.sum())
        unmatched += int((delta & ~valid).sum())   # a delta sample that failed (none expected here)
        counts[-1] += int((~rows).sum())
    probs = [e[3] for e in expected]
    res = discrete_test(list(counts), probs + [1.0 - sum(probs)], alpha=alpha)
    res.details.update({f"count_{name}": int(c) for name, c in zip(names, counts)})
    checks = {"delta_direction": {"ok": bad_dir == 0, "mismatches": bad_dir},
              "delta_radiance": {"ok": bad_value == 0, "mismatches": bad_value},
              "delta_pdf_is_selection": {"ok": bad_pdf == 0, "mismatches": bad_pdf},
              "delta_samples_valid": {"ok": unmatched == 0, "failed": unmatched}}
    return res, checks


def _lobe_run(spec: dict, n: int, seed: int, alpha: float):
    """Counts of reflection and transmission against F and 1 - F; directions and weights."""
    probe: BsdfProbe = spec["probe"]
    wo, ior, F = probe.wo, probe.param, spec["F"]
    mirror = np.array([-wo[0], -wo[1], wo[2]])
    t_dir, t_eta = refract_expected(wo, ior)
    flags_ok = refl_ok = trans_ok = True
    n_refl = n_trans = 0
    t_err = 0.0
    for u in _chunks(n, seed):
        s = probe.sample_full(u)
        wi, weight, eta = s["wi"], s["weight"], s["eta"]
        flags_ok &= bool(s["valid"].all() and s["delta"].all())
        refl = np.all(np.abs(wi - mirror) <= _RTOL, axis=1)
        trans = ~refl
        n_refl += int(refl.sum())
        n_trans += int(trans.sum())
        refl_ok &= bool(np.all(weight[refl] == 1.0) and np.all(eta[refl] == 1.0))
        if trans.any():
            t_err = max(t_err, float(np.abs(wi[trans] - t_dir).max()) if t_dir is not None else math.inf)
            trans_ok &= bool(np.allclose(weight[trans], 1.0 / t_eta ** 2, rtol=_RTOL, atol=0)
                             and np.allclose(eta[trans], t_eta, rtol=_RTOL, atol=0))
    checks = {"all_valid_and_delta": {"ok": flags_ok}, "reflection": {"ok": refl_ok, "count": n_refl}}
    if n_trans:
        checks["transmission_snell"] = {"ok": trans_ok and t_err <= _RTOL, "max_direction_error": t_err,
                                        "count": n_trans}
    res = discrete_test([n_refl, n_trans], [F, 1.0 - F], alpha=alpha)
    res.details.update(F=F, reflected=n_refl, transmitted=n_trans)
    return res, checks


def run_routine(routine: Routine, *, n: int = DEFAULT_N, seed: int = 0, alpha: float = DEFAULT_ALPHA) -> Row:
    """Every test of one routine at false-positive rate ``alpha`` (split by Sidak over its
    statistical sub-tests); the Pearson p-value is the row's ``p_value``."""
    t0 = time.perf_counter()
    spec = routine.make()
    s = routine.seed(seed)
    checks: dict = {}
    if routine.kind == "lobes":
        res, checks = _lobe_run(spec, n, s, alpha)
    else:
        # the chi-square test (itself two: shape and mass), the albedo, the lobe counts
        stat_tests = {"bsdf": 2, "mixed": 3}.get(routine.kind, 1) + (1 if spec.get("deltas") else 0)
        a = sidak(alpha, stat_tests)
        res = chi2_test(spec["sample"], spec["pdf"], domain=spec["domain"], n=n, seed=s, alpha=a,
                        dims=spec["dims"], cos_range=spec.get("cos_range"),
                        resolution=spec.get("resolution", DEFAULT_RESOLUTION))
        if routine.kind == "bsdf":
            grid = Grid.make(spec["domain"], res.resolution)
            checks = _bsdf_checks(spec["probe"], grid, n, s + 1, a)
        elif routine.kind == "mixed":
            lobes, checks = _mixed_checks(spec, Grid.make("hemisphere", res.resolution), n, s + 1, a)
            checks["specular_share"] = {"ok": lobes.verdict == "pass", "p_value": lobes.p_value, **lobes.details}
        elif routine.kind == "light":
            checks = _light_checks(spec["probe"], spec["single"], n, s + 1, spec.get("reported"))
            if spec.get("deltas"):
                shares, delta_checks = _delta_checks(spec["probe"], spec["deltas"], n, s + 2, a)
                checks.update(delta_checks)
                checks["delta_shares"] = {"ok": shares.verdict == "pass", "p_value": shares.p_value, **shares.details}
    failed = [k for k, v in checks.items() if not v["ok"]]
    verdict, message = res.verdict, res.message
    if failed:
        verdict = "fail"
        message = "; ".join(filter(None, [message, "failed checks: " + ", ".join(failed)]))
    return Row(routine=routine.name, params=routine.param_text, n=n, p_value=res.p_value, verdict=verdict,
               seconds=time.perf_counter() - t0, message=message, checks=checks, result=res)
