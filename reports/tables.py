"""Tables of the report: per-strategy statistics, run facts, metric definitions; Markdown and plain text.

Every number in a table is the store's own value printed with :func:`fmt` (4 significant
digits), so the Markdown and the HTML show the same figures as ``summary.json``.
"""
from __future__ import annotations

import math

from benchmarks.constants import BASELINE, CLOSED_FORM, MIN_SLOPE_BUDGETS, RELMSE_EPS
from benchmarks.metrics import DEFAULT_METRIC, SPECS

from .curves import curve_label
from .headline import VERDICT_WORDS, pair_text, percent_text
from .store import num

__all__ = ["fmt", "stats_table", "facts_table", "FORMULAS", "COLUMNS", "columns", "verdict_cell", "p_text",
           "slope_cell"]

DASH = "–"


def columns(metric: str = DEFAULT_METRIC) -> tuple:
    """(header, tooltip) of the per-strategy table under ``metric``, in order.

    >>> columns("relmse")[1][0], columns("rmse")[1][0]
    ('relMSE slope [95% CI]', 'RMSE slope [95% CI]')
    """
    spec = SPECS[metric]
    lab = spec.label
    unbiased = f"; unbiased Monte Carlo gives {spec.unbiased_slope:g}" if spec.unbiased_slope is not None else ""
    return (
        ("renderer / strategy", "ours: our tracer's strategy; Mitsuba: Mitsuba 3's path integrator"),
        (f"{lab} slope [95% CI]", f"least-squares slope of log {lab} over log spp, from {MIN_SLOPE_BUDGETS} or "
                                  f"more rendered budgets (the range fitted is given){unbiased}"),
        ("bias test", "the gate's three-valued test of the seeds' mean at the top budget against the reference: "
                      "pass, fail or undetermined (heavy-tailed at this budget)"),
        ("bias [95% CI]", "relative bias sum(mean - ref) / sum(ref), in percent, with its 95% interval"),
        ("p", "the bias test's p-value, as computed (its levels combined by Bonferroni; "
              "fail when below the run's alpha per curve)"),
        ("noise vs light: equal spp / equal time", "per-sample relative variance (about the estimator's own "
                                                   "expectation) over light sampling's; at equal time x seconds "
                                                   "per sample"),
        (f"efficiency / Mitsuba ({lab})", f"1 / ({lab} x seconds), ours over Mitsuba's path; shown only where no "
                                          "bias was detected"),
        ("time to target (s)", f"seconds to reach the target {lab}; shown only where no bias was detected"),
        ("samples/s", "throughput of the estimator's seconds-long high-budget render (tail reference, Mitsuba's "
                      "reference), else of the sweep's renders"),
        ("samples/s / Mitsuba", "throughput relative to Mitsuba's path"),
    )


#: the table's columns under RMSE (kept for readers of the older name).
COLUMNS = columns("rmse")


def fmt(value, digits: int = 4) -> str:
    """A number with ``digits`` significant digits; ``None``/NaN/non-numbers as a dash."""
    v = num(value)
    if not math.isfinite(v):
        return "inf" if v == math.inf else ("-inf" if v == -math.inf else DASH)
    return f"{v:.{digits}g}"


def verdict_cell(row: dict) -> str:
    """The bias test's verdict in the words of the headline: pass, fail, undetermined (and why)."""
    v = row.get("bias_verdict")
    if v == "undetermined":
        needed = num(row.get("bias_spp_needed"))
        tail = num(row.get("tail_spp_needed"))
        why = (f"needs ~{needed:.0f} spp" if math.isfinite(needed) else
               f"needs a {tail:.0f}-spp tail reference" if math.isfinite(tail) else "heavy-tailed")
        return f"undetermined ({why})"
    return VERDICT_WORDS.get(v, DASH)


def p_text(p) -> str:
    """A p-value as computed: ``< 1e-300`` where it underflows to zero (never a capped z)."""
    p = num(p)
    if not math.isfinite(p):
        return DASH
    return "< 1e-300" if p == 0 else f"{p:.2g}"


def slope_cell(r: dict) -> str:
    """Slope, interval, the budgets fitted, and a flag where it is steeper than Monte Carlo allows."""
    if r.get("slope_status") and r.get("slope") is None:
        return f"{DASH} ({r['slope_status']})"
    ci = r.get("slope_ci")
    out = fmt(r.get("slope"), 3) + (f" [{fmt(ci[0], 3)}, {fmt(ci[1], 3)}]"
                                    if isinstance(ci, (list, tuple)) and len(ci) == 2 else "")
    rng = r.get("slope_range")
    if isinstance(rng, (list, tuple)) and len(rng) == 2:
        out += f", {rng[0]:g}–{rng[1]:g} spp"
    if r.get("slope_steep"):
        out += f" (steeper than {r.get('unbiased_slope'):g}: the low budgets read low, rare paths unseen)"
    elif r.get("slope_status"):
        out += " (undetermined: heavy-tailed)"
    return out


def _cost(row: dict, key: str) -> str:
    """An efficiency or time figure, or why it is not shown ('biased', 'undetermined')."""
    return row.get("cost_status") or fmt(row.get(key))


def stats_table(rows: list[dict]) -> list[list[str]]:
    """Cells of the per-(renderer, strategy) table of one section, one list per summary row.

    ``rows`` are :func:`benchmarks.metrics.view` s of the summary rows (one metric).
    """
    out = []
    for r in rows:
        noise = DASH
        if r.get("strategy") == BASELINE and r.get("renderer") == "ours":
            noise = "baseline"
        elif r.get("exact"):
            noise = "exact"
        elif r.get("noise_vs_light") is not None:
            noise = pair_text(r)
        out.append([
            curve_label(r["renderer"], r["strategy"]),
            slope_cell(r),
            verdict_cell(r),
            percent_text(r.get("relative_bias"), r.get("relative_bias_ci")),
            p_text(r.get("bias_p")),
            noise,
            _cost(r, "efficiency_vs_mitsuba"),
            _cost(r, "time_to_target"),
            fmt(r.get("samples_per_second"), 3),
            fmt(r.get("samples_per_second_vs_mitsuba"), 3),
        ])
    return out


def _build_facts(records) -> list[tuple[str, str]]:
    """One ``build`` fact per build in the records: which curves it rendered, with ``git describe``."""
    by_build: dict = {}
    for r in records or ():
        b = r.get("build") or "unrecorded"
        label = curve_label(r.get("renderer"), r.get("strategy"))
        entry = by_build.setdefault(b, {"git": r.get("build_git"), "curves": {}})
        entry["curves"].setdefault(label, set()).add(str(r.get("scene")))
    out = []
    for b, e in by_build.items():
        git = f" (git {e['git']})" if e["git"] else ""
        curves = "; ".join(f"{c}: {', '.join(sorted(sc))}" for c, sc in e["curves"].items())
        out.append((f"build {b}{git}", curves))
    return out


def _kernel_width(versions: dict) -> str:
    """", LLVM kernels 16-wide for sapphirerapids" where the run recorded Dr.Jit's LLVM target
    (``mitsuba_scenes.variants.llvm_target``), else "": the width sets ``llvm_ad_rgb``'s speed.

    >>> _kernel_width({"llvm_target": {"cpu": "znver3", "vector_width": 8, "avx512": False}})
    ', LLVM kernels 8-wide for znver3'
    >>> _kernel_width({"llvm_target": None}), _kernel_width({})
    ('', '')
    """
    target = versions.get("llvm_target")
    if not isinstance(target, dict) or "vector_width" not in target:
        return ""
    return f", LLVM kernels {target['vector_width']}-wide for {target.get('cpu', DASH)}"


def facts_table(meta: dict, *, n_records: int = 0, n_raw: int = 0, records=None) -> list[tuple[str, str]]:
    """(label, value) pairs of the run facts; missing keys read as a dash.

    ``records`` (the job records shown) add one line per build: which curves it rendered.
    """
    meta = meta if isinstance(meta, dict) else {}
    machine = meta.get("machine") if isinstance(meta.get("machine"), dict) else {}
    versions = meta.get("versions") if isinstance(meta.get("versions"), dict) else {}

    def s(v):
        return DASH if v is None or v == "" else str(v)

    total = num(meta.get("total_seconds"))
    total_txt = DASH if not math.isfinite(total) else f"{fmt(total)} s" + (
        f" ({total / 60:.1f} min)" if total >= 120 else "")
    facts = [
        ("date", s(meta.get("date"))),
        ("preset", s(meta.get("preset"))),
        ("total time", total_txt),
        ("threads", s(meta.get("threads"))),
        ("machine", f"{s(machine.get('cpu'))}, {s(machine.get('cores'))} cores, {s(machine.get('platform'))}"),
        ("rtbench", s(versions.get("rtbench"))),
        ("Mitsuba", f"{s(versions.get('mitsuba'))} ({s(versions.get('variant'))})" + _kernel_width(versions)),
        ("Python / NumPy", f"{s(versions.get('python'))} / {s(versions.get('numpy'))}"),
        ("job records", f"{n_records}" + (f" ({n_raw - n_records} duplicates dropped)" if n_raw > n_records else "")),
    ]
    facts.extend(_build_facts(records))
    files = meta.get("scene_files") if isinstance(meta.get("scene_files"), dict) else {}
    for name, f in sorted(files.items()):
        f = f if isinstance(f, dict) else {}
        params = f.get("params") or {}
        facts.append((f"scene {name}", f"{s(f.get('source'))}" + (f" ({', '.join(f'{k}={v}' for k, v in sorted(params.items()))})" if params else "")
                      + f", content hash {s(f.get('hash'))}"))
    refs = meta.get("references") if isinstance(meta.get("references"), dict) else {}
    if refs:
        facts.append(("references", "; ".join(
            f"{scene}: {s(reference_caption(r if isinstance(r, dict) else {}))}" for scene, r in sorted(refs.items()))))
    return facts


def reference_caption(info: dict) -> str:
    """What a reference is: a closed form says so (its spp is a placeholder), a render gives its budget."""
    if info.get("variant") == CLOSED_FORM:
        return "closed form (exact)"
    return f"Mitsuba, {info.get('spp', '?')} spp, seed {info.get('seed', '?')}"


#: (name, definition) of every metric in the tables and plots, epsilons included.
FORMULAS = (
    ("MSE, RMSE", "MSE = mean over pixels and RGB channels of (x - ref)^2 on linear radiance; RMSE = sqrt(MSE)."),
    ("relMSE", f"mean of (x - ref)^2 / (ref^2 + eps) with eps = {RELMSE_EPS:g}."),
    ("corrected MSE", "MSE - mean(Var_ref / N_ref): the reference's own noise (per-sample variance Var_ref "
                      "over its N_ref samples) biases MSE upwards and is subtracted."),
    ("bias test", "the gate's test of the mean over the seeds at the top budget against the reference "
                  "(benchmarks/STATISTICS.md): summed differences per pixel, per tile and over the image, each "
                  "standardised by the estimator's variance (floored by its tail reference's) and the reference's, "
                  "tested only where its normal approximation holds; p is the smallest Sidak-adjusted level p "
                  "times the number of levels (Bonferroni), as computed. pass / fail (p below the run's alpha per "
                  "curve) / undetermined (the image-level statistic is too heavy-tailed at this budget: the spp "
                  "that would decide is given)."),
    ("bias", "relative bias sum(mean_k x_k - ref) / sum(ref) at the top budget, in percent; 95% interval from the "
             "per-sample variance over K x spp samples and the reference's own."),
    ("noise", "per-sample relative variance about the estimator's own expectation, mean over pixels and "
              f"channels of Var / (ref^2 + {RELMSE_EPS:g}), from a high-budget render of the same estimator (our "
              "16384-spp tail reference; Mitsuba's reference); against light sampling's at equal spp, and times "
              "seconds per sample at equal time (its 95% interval from the fourth moments; timing noise not "
              "included)."),
    ("SSIM", "on display images (exposure from the reference, clip to [0, 1], sRGB transfer via colour-science): "
             "skimage structural_similarity with data_range=1, gaussian_weights=True, sigma=1.5, "
             "use_sample_covariance=False, channel_axis=-1."),
    ("FLIP", "NVIDIA's perceptual difference (Andersson et al. 2020, flip-evaluator), LDR mode on the same "
             "display images as SSIM, 67 pixels per degree; mean over pixels, 0 = identical. Error maps: per pixel, "
             "linear scale 0 to 1 (magma)."),
    ("metric", "--metric chooses the error behind slopes, efficiency and time to target: RMSE (sqrt of the "
               "corrected MSE), relMSE (minus the reference's relative noise; the default, the convention of "
               "rendering papers), 1 - SSIM, or FLIP; every table and plot names it."),
    ("slope", "least-squares slope of log error over log spp, one point per spp (the seed mean); unbiased Monte "
              "Carlo gives -1/2 for RMSE and -1 for relMSE; SSIM and FLIP have no theoretical value. A flattening "
              "curve is bias."),
    ("efficiency", "1 / (error x seconds) at the highest spp, error the metric's (MSE for RMSE); for estimators "
                   "found unbiased the expected MSE / relMSE from the tail reference's variance. Relative to "
                   "Mitsuba: ours / Mitsuba's path integrator, same scene. Shown only where no bias was detected: "
                   "'biased' or 'undetermined' otherwise (an efficiency of a biased estimator means nothing)."),
    ("time to target", "seconds to reach the target error, log-log interpolated on the error-time curve: RMSE: "
                       "0.1 x the reference's RMS radiance; relMSE 0.01; 1 - SSIM 0.05; FLIP 0.05. Shown only "
                       "where no bias was detected."),
    ("throughput", "samples per second of the estimator's seconds-long high-budget render (our tail reference, "
                   "Mitsuba's reference); relative to Mitsuba as a ratio. Equal-time figures use the same timing."),
    ("images", "tone-mapped alike: scaled by k from the reference, the larger of 0.18 / (median luminance) and "
               "1 / (99th-percentile luminance, the SSIM's exposure), clipped to [0, 1], sRGB transfer. "
               f"Error maps: per-pixel (x - ref)^2 / (ref^2 + {RELMSE_EPS:g}), "
               "mean over channels, log colour scale shared within a scene; the seed-0 image of each job."),
    ("median and band", "curves show the median over seeds; the shaded band spans the minimum to maximum."),
)
