"""The A/B page of ``rtbench compare``: both curves of each scene and strategy on one plot,
side by side with the figures of :func:`benchmarks.compare.compare_stores` (computed there)."""
from __future__ import annotations

import base64
import html
from pathlib import Path

from reference_tracer.imageio import atomic_write

from benchmarks.display import pyplot
from benchmarks.text import markdown, markdown_table

from .plots import plain_text

__all__ = ["plot_pair", "write_compare_page"]


@plain_text
def plot_pair(cmp, path, *, name_a: str = "A", name_b: str = "B") -> Path:
    """RMSE vs spp of A and B (log-log) for one :class:`benchmarks.compare.CurveComparison`."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(4.2, 3.2), dpi=100)
    for spps, rmse, label, style in ((cmp.spps_a, cmp.rmse_a, name_a, "o-"), (cmp.spps_b, cmp.rmse_b, name_b, "s--")):
        pts = [(s, r) for s, r in zip(spps, rmse) if r > 0]
        if pts:
            ax.loglog(*zip(*pts), style, label=label, ms=4)
    ax.set_xlabel("spp")
    ax.set_ylabel("RMSE (noise-corrected)")
    ax.set_title(cmp.label, fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def _f(v, fmt="{:.3g}"):
    return "-" if v is None else fmt.format(v)


def figures(cmp) -> list:
    """(label, value) rows of one comparison."""
    ci = lambda c, fmt="{:.3g}": "-" if c is None else f"[{fmt.format(c[0])}, {fmt.format(c[1])}]"  # noqa: E731
    return [("builds", f"A {cmp.build_a or '-'} / B {cmp.build_b or '-'}"),
            ("slope A / B", f"{_f(cmp.slope_a)} / {_f(cmp.slope_b)}"),
            ("slope B - A (95% bootstrap)", f"{_f(cmp.slope_diff, '{:+.3f}')} {ci(cmp.slope_diff_ci, '{:+.3f}')}"),
            (f"efficiency B / A at {cmp.top_spp} spp (95% bootstrap)",
             f"{_f(cmp.efficiency_ratio)} {ci(cmp.efficiency_ratio_ci)}: {cmp.speed}"),
            ("gate: B against A as reference", f"{cmp.verdict or '-'} (p = {_f(cmp.p_value)}, relative bias "
                                               f"{_f(cmp.relative_bias, '{:+.2%}')})"),
            ("B's estimator at a high budget", getattr(cmp, "tails", "") or "-"),
            ("why", cmp.reason or "-")]


def write_compare_page(comparisons, out, *, name_a: str, name_b: str) -> Path:
    """``out/index.html`` (self-contained) and ``out/compare.md``: one plot and table per curve."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    blocks, md = [], [f"# rtbench compare: A = {markdown(name_a)}, B = {markdown(name_b)}", ""]
    for i, cmp in enumerate(comparisons):
        png = plot_pair(cmp, out / f"curve_{i:03d}.png", name_a="A", name_b="B")
        data = base64.b64encode(png.read_bytes()).decode()
        rows = "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in figures(cmp))
        blocks.append(f'<section><h2>{html.escape(cmp.label)}</h2><div class="pair"><img src="data:image/png;base64,'
                      f'{data}" alt="RMSE curves"><table>{rows}</table></div></section>')
        md += [f"## {markdown(cmp.label)}", "", f"![curves]({png.name})", "",
               markdown_table(["figure", "value"], figures(cmp)), ""]
    page = out / "index.html"
    atomic_write(page, "<!doctype html><meta charset='utf-8'><title>rtbench compare</title><style>"
                    "body{font-family:sans-serif;margin:1em}.pair{display:flex;gap:1em;align-items:flex-start}"
                    "th{text-align:left;padding-right:1em}</style>"
                    f"<h1>rtbench compare</h1><p>A = {html.escape(name_a)}<br>B = {html.escape(name_b)}</p>"
                    + "".join(blocks))
    atomic_write(out / "compare.md", "\n".join(md) + "\n")
    return page
