"""``rtbench chi2 [--routine PREFIX ...] [--samples N] [--seed S] [--alpha A] [--out DIR] [--json PATH]``:
chi-square tests of every sampling routine (warps, BSDFs, glass lobes, light sampling)."""
from __future__ import annotations

from benchmarks.commands import _args as A

HELP = "chi-square tests of every sampling routine against its pdf; observed-vs-expected images; exit 1 on a failure"

DEFAULT_SAMPLES = 1_000_000
DEFAULT_OUT = "rtbench-out/chi2"


def add_arguments(parser) -> None:
    from benchmarks.chi2.pearson import DEFAULT_ALPHA

    parser.add_argument("--routine", action="append", metavar="PREFIX", default=[],
                        help="run only routines whose name starts with PREFIX (repeatable), e.g. bsdf.rough_conductor, "
                             "light., warp.uniform_cone; --list shows them (default: every routine)")
    A.add_list_arg(parser)
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES, help="samples per routine")
    A.add_seed_args(parser)
    A.add_alpha_args(parser, default=DEFAULT_ALPHA)
    A.add_out_arg(parser, default=DEFAULT_OUT)
    parser.add_argument("--images", choices=("all", "failures", "none"), default="all",
                        help="which routines get an observed-vs-expected image")
    A.add_json_arg(parser)
    A.add_quiet_arg(parser)


def run(args) -> int:
    from benchmarks.chi2.catalogue import select
    from benchmarks.chi2.pearson import sidak
    from benchmarks.chi2.plot import file_name, save_histograms
    from benchmarks.chi2.runner import run_routine
    from benchmarks.store import write_json
    from benchmarks.text import terminal, text_table

    routines = select(args.routine)        # ValueError (exit 2) for a prefix that matches nothing
    if args.list:
        print("\n".join(r.label for r in routines))
        return 0
    per_test = sidak(args.alpha, len(routines))
    rows = []
    with A.progress_bar(args, stderr=False) as progress:
        task = progress.add_task("chi2", total=len(routines))
        for r in routines:
            progress.update(task, description=f"chi2 {r.label}")
            row = run_routine(r, n=args.samples, seed=args.seed, alpha=per_test)
            rows.append((r, row))
            if not row.passed:
                progress.console.print(f"  {r.label}: {row.verdict} - {row.message}", style="dim",
                                       highlight=False, markup=False)
            progress.advance(task)
    images = 0   # an OSError while writing: exit 3 (benchmarks.cli)
    for r, row in rows:
        if row.result is not None and (args.images == "all" or args.images == "failures" and not row.passed):
            save_histograms(row.result, f"{args.out}/{file_name(r.label)}", title=r.label)
            images += 1
    if args.json:
        write_json(args.json, [row.to_json() for _, row in rows])
    if not args.quiet:
        print(f"rtbench chi2: {len(rows)} routines, {args.samples} samples each, alpha {args.alpha} for the run "
              f"({per_test:.2e} per routine)")
        print(text_table(["routine", "params", "n", "p-value", "verdict", "s"],
                         [[row.routine, row.params, row.n, f"{row.p_value:.3g}", row.verdict, f"{row.seconds:.1f}"]
                          for _, row in rows]))
    if images:
        print(f"{images} images in {args.out}/")
    for verdict in ("undetermined", "fail"):
        for r, row in rows:
            if row.verdict == verdict:
                print(terminal(f"{'failed' if verdict == 'fail' else verdict} {r.label}: {row.message}"))
    return 1 if any(row.verdict == "fail" for _, row in rows) else 0
