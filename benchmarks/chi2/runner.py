"""One routine of the catalogue (:class:`Routine`), and the runner behind ``rtbench chi2``
(:func:`run_routine`): its chi-square test and the checks beside it (README.md here, "Checks
beside the distribution"), with their outcome (:class:`Row`)."""
from __future__ import annotations

import math
import time
import zlib
from collections import Counter
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..constants import LUMINANCE_WEIGHTS

from .pearson import (DEFAULT_ALPHA, DEFAULT_N, DEFAULT_RESOLUTION, Chi2Result, Grid, chi2_test, discrete_test,
                      excess_p_value, integrate, sidak, uniform_chunks)
from .probes import BsdfProbe, LightProbe, refract_expected

__all__ = ["Routine", "Row", "run_routine"]

# Relative tolerance of the deterministic identities (weight = eval / pdf, the sampler's pdf
# = pdf(), mirror and Snell directions): the same double-precision routines on both sides.
_RTOL = 1e-9
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


def _off(a, b, rtol: float = _RTOL) -> int:
    """Entries (rows of 2-D arrays) where ``a`` is not ``b`` within ``rtol``."""
    bad = ~np.isclose(a, b, rtol=rtol, atol=0)
    return int((bad.any(axis=1) if bad.ndim == 2 else bad).sum())


def _near(a, b, tol: float = _RTOL) -> np.ndarray:
    """Rows of ``a`` within ``tol`` of ``b`` in every coordinate."""
    return np.all(np.abs(a - b) <= tol, axis=1)


def _check(bad: int, key: str = "mismatches", **more) -> dict:
    return {"ok": bad == 0, key: bad, **more}


def _moments(wl: np.ndarray) -> dict:
    return {"w_sum": float(wl.sum()), "w_sq": float((wl * wl).sum())}


def _mismatches(s: dict, rows, probe: BsdfProbe) -> dict:
    """Samples ``rows`` whose weight is not eval / pdf, and whose pdf is not pdf()."""
    ev = probe.eval_pdf(s["wi"][rows])
    return {"weight": _off(s["weight"][rows], ev["value"] / ev["pdf"][:, None]), "pdf": _off(s["pdf"][rows], ev["pdf"])}


def _albedo_check(probe: BsdfProbe, grid: Grid, n: int, t: Counter, level: float, *,
                  offset: float = 0.0, key: str = "expected") -> dict:
    """The integral of f cos (plus ``offset``, a Dirac lobe's share; reported as ``key``) against
    the mean of ``n`` weights, from their :func:`_moments` in ``t``."""
    mean = t["w_sum"] / n
    se = math.sqrt(max(t["w_sq"] / n - mean * mean, 0.0) / max(n - 1, 1))
    integ, err, _, bad = integrate(lambda d: probe.eval_pdf(d)["value"] @ _LUM, grid, n=n)
    albedo = offset + float(integ.sum())
    p = excess_p_value(albedo - mean, err + _RTOL * abs(albedo), se)
    return {"ok": p >= level and bad == 0, key: albedo, "mean_weight": mean, "se": se,
            "integration_error": err, "p_value": p}


def _share(res: Chi2Result, **details) -> dict:
    """The check of a discrete test of lobe or light counts."""
    return {"ok": res.verdict == "pass", "p_value": res.p_value, **details}


def _bsdf_checks(probe: BsdfProbe, grid: Grid, n: int, seed: int, level: float) -> dict:
    """weight = eval / pdf and pdf = pdf() at every sample; albedo = mean weight."""
    t = Counter()
    for u in uniform_chunks(n, seed):
        s = probe.sample_full(u)
        valid = s["valid"].astype(bool)
        t.update(_mismatches(s, valid, probe), samples=int(valid.sum()),
                 **_moments(s["weight"][valid] @ _LUM))    # failed samples weigh 0
    return {"weight_is_eval_over_pdf": _check(t["weight"], samples=t["samples"]),
            "sample_pdf_is_pdf": _check(t["pdf"]),
            "albedo": _albedo_check(probe, grid, n, t, level, key="integral_f_cos")}


def _mixed_checks(spec: dict, grid: Grid, n: int, seed: int, level: float) -> dict:
    """The smooth plastic's samples (README.md here, "What is tested"); the lobes' counts at ``level``."""
    probe: BsdfProbe = spec["probe"]
    wo, F, ks, p_specular = probe.wo, spec["F"], spec["specular"], spec["p_specular"]
    mirror = np.array([-wo[0], -wo[1], wo[2]])
    t = Counter()
    for u in uniform_chunks(n, seed):
        s = probe.sample_full(u)
        valid, delta = s["valid"].astype(bool), s["delta"].astype(bool)
        spec_rows, diff_rows = valid & delta, valid & ~delta
        t.update(_mismatches(s, diff_rows, probe), direction=int((~_near(s["wi"][spec_rows], mirror)).sum()),
                 specular_weight=_off(s["weight"][spec_rows], ks * (F / p_specular)),
                 specular=int(spec_rows.sum()), diffuse=int(diff_rows.sum()),
                 **_moments(np.where(valid, s["weight"] @ _LUM, 0.0)))
    n_spec = t["specular"]
    res = discrete_test([n_spec, n - n_spec], [p_specular, 1.0 - p_specular], alpha=level)
    return {
        "specular_is_mirror": _check(t["direction"], samples=n_spec),
        "specular_weight_is_ks_F_over_Ps": _check(t["specular_weight"]),
        "diffuse_weight_is_eval_over_pdf": _check(t["weight"], samples=t["diffuse"]),
        "sample_pdf_is_pdf": _check(t["pdf"]),
        "every_sample_valid": _check(n - n_spec - t["diffuse"], "invalid"),
        "albedo": _albedo_check(probe, grid, n, t, level, offset=float(ks @ _LUM) * F),
        "specular_share": _share(res, p_specular=p_specular, specular=n_spec, other=n - n_spec),
    }


def _light_checks(probe: LightProbe, single: bool, n: int, seed: int, reported=None) -> dict:
    """Each sample's pdf against light_pdf, and light_pdf against ``reported`` (a function of world
    directions) if given; delta lights' samples are :func:`_delta_checks`'s."""
    t = Counter()
    worst = 0.0
    for u in uniform_chunks(n, seed):
        s = probe.sample_full(u)
        valid = s["valid"].astype(bool) & ~s["delta"].astype(bool)
        wi = np.ascontiguousarray(s["wi"][valid])
        pdf = s["pdf"][valid]
        lp = probe.core.light_pdf(np.ascontiguousarray(np.broadcast_to(probe.ref, wi.shape)), wi)
        if single:
            t.update(pdf=_off(pdf, lp, _LIGHT_RTOL))
            worst = max(worst, float(np.max(np.abs(pdf / np.where(lp > 0, lp, np.inf) - 1.0), initial=0.0)))
        else:
            t.update(pdf=int((pdf > lp * (1 + _LIGHT_RTOL)).sum()))
        t.update(pdf_all=_off(s["pdf_all"][valid], lp), samples=int(valid.sum()),
                 reported=_off(lp, reported(wi), _LIGHT_RTOL) if reported is not None else 0)
    checks = {"sample_pdf_matches_light_pdf": _check(t["pdf"], samples=t["samples"],
                                                     worst_relative=worst if single else None),
              "pdf_all_is_light_pdf": _check(t["pdf_all"])}
    if reported is not None:
        checks["light_pdf_is_mitsubas_shading_density"] = _check(t["reported"])
    return checks


def _delta_checks(probe: LightProbe, expected: list, n: int, seed: int, alpha: float) -> dict:
    """The delta lights' samples against the ``expected`` ``(name, wi, radiance, pmf)`` of each, and
    their counts against the pmfs at ``alpha`` (the other samples one outcome)."""
    wis = np.array([e[1] for e in expected], dtype=np.float64)
    counts = np.zeros(len(expected) + 1, dtype=np.int64)
    t = Counter()
    for u in uniform_chunks(n, seed):
        s = probe.sample_full(u)
        valid, delta = s["valid"].astype(bool), s["delta"].astype(bool)
        rows = valid & delta
        wi, pdf, radiance = s["wi"][rows], s["pdf"][rows], s["radiance"][rows]
        which = np.argmax(wi @ wis.T, axis=1) if len(wi) else np.zeros(0, dtype=int)
        for k, (_, w, value, pmf) in enumerate(expected):
            m = which == k
            t.update(direction=int((~_near(wi[m], np.asarray(w), 1e-12)).sum()),
                     radiance=_off(radiance[m], np.asarray(value, dtype=float)), pdf=_off(pdf[m], pmf))
            counts[k] += int(m.sum())
        t.update(failed=int((delta & ~valid).sum()))   # a delta sample that failed (none expected here)
        counts[-1] += int((~rows).sum())
    probs = [e[3] for e in expected]
    res = discrete_test(list(counts), probs + [1.0 - sum(probs)], alpha=alpha)
    return {"delta_direction": _check(t["direction"]), "delta_radiance": _check(t["radiance"]),
            "delta_pdf_is_selection": _check(t["pdf"]), "delta_samples_valid": _check(t["failed"], "failed"),
            "delta_shares": _share(res, **{f"count_{e[0]}": int(c) for e, c in zip(expected, counts)})}


def _lobe_run(spec: dict, n: int, seed: int, alpha: float):
    """Counts of reflection and transmission against F and 1 - F; directions and weights."""
    probe: BsdfProbe = spec["probe"]
    wo, ior, F = probe.wo, probe.param, spec["F"]
    t_dir, t_eta = refract_expected(wo, ior)
    t = Counter()   # the counts, and of chunks that fail a check
    t_err = 0.0
    for u in uniform_chunks(n, seed):
        s = probe.sample_full(u)
        wi, weight, eta = s["wi"], s["weight"], s["eta"]
        refl = _near(wi, np.array([-wo[0], -wo[1], wo[2]]))
        trans = ~refl
        t.update(flags=not (s["valid"].all() and s["delta"].all()), reflected=int(refl.sum()),
                 transmitted=int(trans.sum()), refl=not (np.all(weight[refl] == 1.0) and np.all(eta[refl] == 1.0)))
        if trans.any():
            t_err = max(t_err, float(np.abs(wi[trans] - t_dir).max()) if t_dir is not None else math.inf)
            t.update(trans=not (np.allclose(weight[trans], 1.0 / t_eta ** 2, rtol=_RTOL, atol=0)
                                and np.allclose(eta[trans], t_eta, rtol=_RTOL, atol=0)))
    n_refl, n_trans = t["reflected"], t["transmitted"]
    checks = {"all_valid_and_delta": {"ok": t["flags"] == 0}, "reflection": {"ok": t["refl"] == 0, "count": n_refl}}
    if n_trans:
        checks["transmission_snell"] = {"ok": t["trans"] == 0 and t_err <= _RTOL, "max_direction_error": t_err,
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
            checks = _mixed_checks(spec, Grid.make("hemisphere", res.resolution), n, s + 1, a)
        elif routine.kind == "light":
            checks = _light_checks(spec["probe"], spec["single"], n, s + 1, spec.get("reported"))
            if spec.get("deltas"):
                checks.update(_delta_checks(spec["probe"], spec["deltas"], n, s + 2, a))
    failed = [k for k, v in checks.items() if not v["ok"]]
    verdict, message = res.verdict, res.message
    if failed:
        verdict = "fail"
        message = "; ".join(filter(None, [message, "failed checks: " + ", ".join(failed)]))
    return Row(routine=routine.name, params=routine.param_text, n=n, p_value=res.p_value, verdict=verdict,
               seconds=time.perf_counter() - t0, message=message, checks=checks, result=res)
