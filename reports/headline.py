"""The report's first table, one row per scene: the answer to the run's question.

For each scene: our tracer against the reference (the verdict of our ``mis`` curve: pass,
fail or undetermined, with the smallest bias it would catch), the bias of light sampling
in percent, and each strategy's noise relative to light sampling at equal spp and at
equal time. The figures are the summary's (:mod:`benchmarks.sweep.headline`); this module
only words them, once, for the page, ``summary.md``, ``headline.csv`` and the terminal.

Examples
--------
>>> ratio_text(3.14159, [2.9, 3.4])
'×3.14 ±8.2%'
>>> ratio_text(0.0, None, exact=True)
'exact'
"""
from __future__ import annotations

from benchmarks.constants import BASELINE, STRATEGIES, VERDICT_STRATEGY
from benchmarks.numbers import is_finite

from .curves import curve_label
from .store import Store, num

__all__ = ["VERDICT_WORDS", "headline_entries", "headline_header", "headline_cells", "ratio_text", "verdict_text",
           "percent_text", "pair_text", "HEADLINE_NOTE"]

#: the three verdicts, worded the same on the page, in the CSVs and in the terminal.
VERDICT_WORDS = {"pass": "pass", "fail": "fail", "undetermined": "undetermined", None: "–"}

HEADLINE_NOTE = (
    f"Noise: each strategy's per-sample relative variance about its own expectation, mean of Var/(ref²+0.01), from "
    f"a high-budget render of the same estimator (ours: its 16384-spp tail reference; Mitsuba: its reference), over "
    f"{BASELINE} sampling's; at equal time, noise × seconds per sample over {BASELINE}'s; ± the half-width of the 95% "
    f"interval; ≥ a lower bound (single samples carry the variance). Ours vs Mitsuba: the bias test of our "
    f"{VERDICT_STRATEGY} curve against the reference (Mitsuba's, or the scene's closed form) at the top budget, with "
    f"the smallest relative bias it would catch. {BASELINE.capitalize()} bias: {BASELINE} sampling misses indirect "
    f"light by design. Where {BASELINE} sampling is exact (the furnace) a strategy's own noise per sample is shown.")


def ratio_text(r, ci=None, *, exact: bool = False, lower_bound: bool = False) -> str:
    """A noise ratio with the half-width of its 95% interval in percent, ``×3.14 ±2.1%``: two
    decimals below 10, three digits above; ``exact`` for zero noise; ``≥`` for a lower bound.

    >>> ratio_text(923.4, [916.0, 929.0])
    '×923 ±0.8%'
    """
    if exact:
        return "exact"
    if not is_finite(r):
        return "–"
    x = num(r)
    out = f"{'≥' if lower_bound else '×'}" + (f"{x:.2f}" if abs(x) < 10 else f"{x:.3g}" if abs(x) < 1000
                                              else f"{x:.0f}")
    if ci and all(is_finite(c) for c in ci) and x > 0:
        half = max(num(ci[1]) / x - 1.0, 1.0 - num(ci[0]) / x)
        out += f" ±{100 * half:.2g}%"
    return out


def percent_text(value, ci=None) -> str:
    """A relative bias in percent with the half-width of its 95% interval: ``−21.3% ±0.6``.

    >>> percent_text(-0.2131, [-0.219, -0.2072])
    '−21.3% ±0.59'
    """
    if not is_finite(value):
        return "–"
    out = f"{100 * num(value):+.1f}%".replace("-", "−")
    if ci and all(is_finite(c) for c in ci):
        out += f" ±{100 * (num(ci[1]) - num(ci[0])) / 2:.2g}"
    return out


def verdict_text(entry: dict) -> str:
    """``pass, catches ±3.3%``, ``fail``, ``undetermined, needs ~120000 spp``: the verdict
    and the smallest relative bias it would catch (or the budget that would decide)."""
    v = entry.get("verdict")
    word = VERDICT_WORDS.get(v, str(v))
    if v in ("pass", "fail") and is_finite(entry.get("min_detectable_bias")):
        word += f", catches ±{100 * num(entry['min_detectable_bias']):.2g}%"
    elif v == "undetermined" and is_finite(entry.get("verdict_spp_needed")):
        word += f", needs ~{num(entry['verdict_spp_needed']):.0f} spp"
    return word


def headline_entries(store: Store) -> list:
    """The summary's headline entries (one per scene and size with noise figures: the sweep's
    main sections, not the seed's single-seed one), in section order; empty if none."""
    entries = [e for e in store.headline if isinstance(e, dict) and isinstance(e.get("scene"), str)
               and any(is_finite(c.get("noise")) for c in e.get("curves") or [])]  # sections without tails: none
    order = {k: i for i, k in enumerate(store.sections())}
    return sorted(entries, key=lambda e: order.get((e["scene"], e.get("width"), e.get("height")), 1e9))


def _columns(entries) -> list:
    """The curves shown: our strategies in order but the baseline, then Mitsuba's."""
    seen = {(c.get("renderer"), c.get("strategy")) for e in entries for c in e.get("curves") or []}
    ours = [("ours", s) for s in STRATEGIES if s != BASELINE and ("ours", s) in seen]
    # another renderer's curve only where it has a noise figure (Mitsuba's: from its reference,
    # the render of its own estimator)
    measured = {(c.get("renderer"), c.get("strategy")) for e in entries for c in e.get("curves") or []
                if is_finite(c.get("noise"))}
    return ours + sorted(k for k in seen if k[0] != "ours" and k in measured)


def headline_header(entries) -> list:
    cols = _columns(entries)
    names = [curve_label(r, s) for r, s in cols]
    return ["scene", "ours vs Mitsuba", f"{BASELINE} bias"] + [f"{n}: equal spp / equal time" for n in names]


def pair_text(c: dict, *, interval: bool = True) -> str:
    """A curve's noise against the baseline at equal spp and at equal time, and the half-width of
    their 95% interval (one: the timing's noise is not in it): ``×923 / ×1610 ±0.7%``."""
    lb, exact = bool(c.get("noise_lower_bound")), bool(c.get("exact"))
    if exact:
        return "exact"
    spp = ratio_text(c.get("noise_vs_light"), None, lower_bound=lb)
    tim = ratio_text(c.get("time_noise_vs_light"), None, lower_bound=lb)
    out = f"{spp} / {tim}"
    ci = c.get("noise_vs_light_ci")
    if interval and ci and all(is_finite(v) for v in ci) and is_finite(c.get("noise_vs_light")):
        out += ratio_text(c["noise_vs_light"], ci)[len(spp):]
    return out


def headline_cells(entries, *, intervals: bool = True) -> list:
    """Rows of text cells (see :func:`headline_header`); without ``intervals`` (a terminal) the
    ratios are shown alone."""
    cols = _columns(entries)
    rows = []
    for e in entries:
        by = {(c.get("renderer"), c.get("strategy")): c for c in e.get("curves") or []}
        base_exact = bool((by.get(("ours", BASELINE)) or {}).get("exact"))
        size = f" {e['width']}×{e['height']}" if e.get("width") and e.get("height") else ""
        ref = f" (vs {e['reference']})" if e.get("reference") and not str(e["reference"]).startswith("Mitsuba") \
            else ""
        bias = percent_text(e.get("light_bias"), e.get("light_bias_ci") if intervals else None)
        row = [f"{e['scene']}{size}", verdict_text(e) + ref, bias + (f" ({BASELINE} exact)" if base_exact else "")]
        for key in cols:
            c = by.get(key)
            if c is None:
                row.append("–")
            elif base_exact and not c.get("exact") and is_finite(c.get("noise")):
                # no ratio to a zero: the strategy's own noise per sample instead
                row.append(f"{'≥' if c.get('noise_lower_bound') else ''}{num(c['noise']):.3g} per sample")
            else:
                row.append(pair_text(c, interval=intervals))
        rows.append(row)
    return rows
