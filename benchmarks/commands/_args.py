"""The one vocabulary of ``rtbench``'s options: every option two subcommands share is defined here once.

Each ``add_*`` function adds one idea with one name, one meaning and one help text; a
subcommand may choose its own *default* only for the options in
:data:`PER_COMMAND_DEFAULTS` (a budget or a size suits each command differently), and
:class:`HelpFormatter` then shows that default in ``--help``. Options whose default is
``None`` say in their help text what happens without them (``--threads``: all cores).
``tests/benchmarks/commands/test_cli_args.py`` walks every subcommand's parser and holds the vocabulary to
this.

Meanings fixed here
-------------------
``--alpha``
    The false-alarm rate of the whole run: the probability that *any* of the run's tests
    of a correct renderer fails. A run of k tests tests each at about alpha / k
    (Bonferroni, or Sidak for ``chi2``).
``--height``
    Defaults to ``--width`` everywhere.
``--threads``
    Defaults to all cores everywhere, for our tracer and Mitsuba alike.
``--quiet``
    No progress output and no tables; only the final lines (paths written, the verdict).
``--reference-spp``
    Samples per pixel of the cached Mitsuba references (``--ref-spp`` is a hidden,
    deprecated alias).

Examples
--------
>>> import argparse
>>> p = argparse.ArgumentParser(formatter_class=HelpFormatter)
>>> add_size_args(p, width=32)
>>> a = check(p.parse_args(["--width", "48"]))
>>> a.width, resolve_height(a)
(48, 48)
"""
from __future__ import annotations

import argparse
import re

__all__ = [
    "HelpFormatter", "PER_COMMAND_DEFAULTS", "METRICS", "DEFAULT_METRIC", "FORMATS", "DEFAULT_ALPHA",
    "ListAction", "check", "formats", "int_list", "name_list", "base_help",
    "add_scene_args", "add_size_args", "resolve_height", "add_spp_args", "add_spps_arg", "add_strategy_args",
    "add_variant_args", "add_seed_args", "add_seeds_arg", "add_threads_args", "add_cache_arg", "add_alpha_args",
    "add_quiet_arg", "add_out_arg", "add_json_arg", "add_list_arg", "add_reference_spp_arg", "add_tail_spp_arg",
    "add_metric_arg", "add_format_arg", "add_scheduler_arg", "single_variant", "resolve_threads",
    "tail_spp_warning",
]

#: options whose default a subcommand chooses (name, meaning and help text are still shared).
PER_COMMAND_DEFAULTS = frozenset({
    "--spp", "--spps", "--width", "--seed", "--seeds", "--out", "--reference-spp", "--strategies", "--variant",
})

#: the error metrics ``--metric`` chooses from, for slopes, efficiency and time to target.
METRICS = ("rmse", "relmse", "ssim", "flip")
#: relMSE: the convention of rendering papers (scale-free, so bright lights do not dominate it).
DEFAULT_METRIC = "relmse"
#: what ``rtbench report --format`` can write.
FORMATS = ("html", "svg", "pdf", "csv")
#: the false-alarm rate of a whole run (``benchmarks.constants.GATE_ALPHA``).
DEFAULT_ALPHA = 0.01

_DEFAULT_CLAUSE = re.compile(r"\s*\(default:? [^()]*(\([^()]*\)[^()]*)*\)\s*$")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Every default visible: appends ``(default: X)`` to an option's help.

    Skipped where the default is None, False or suppressed (the help text then says what
    happens without the option) and where the help already names its default.
    """

    def _get_help_string(self, action):
        text = action.help or ""
        d = action.default
        if (d is None or d is False or d is argparse.SUPPRESS or (isinstance(d, tuple) and not d) or "%(default)" in text or "(default" in text
                or not action.option_strings and action.nargs not in ("?", "*")):
            return text
        if isinstance(d, (list, tuple)):
            return text + " (default: " + ",".join(map(str, d)).replace("%", "%%") + ")"
        return text + " (default: %(default)s)"


def base_help(text: str) -> str:
    """An option's help without its trailing ``(default ...)`` clause (what the vocabulary test compares).

    >>> base_help("image height in pixels (default: the width)")
    'image height in pixels'
    """
    return _DEFAULT_CLAUSE.sub("", text or "")


# Values are range-checked by :func:`check` (a ``ValueError``: one line, exit 2, as every other bad
# input), not by argparse types, whose errors print the whole usage and exit on their own.

def int_list(text, *, option: str = "value") -> tuple:
    """``"1,2,4"`` (or a sequence) -> ``(1, 2, 4)``, every value >= 1; ``ValueError`` naming ``option``.

    >>> int_list("1, 2,4")
    (1, 2, 4)
    """
    if isinstance(text, (list, tuple)):
        text = ",".join(map(str, text))
    try:
        values = tuple(int(v) for v in str(text).split(",") if v.strip())
    except ValueError:
        raise ValueError(f"{option} must be comma-separated integers, got {text!r}") from None
    if not values:
        raise ValueError(f"{option} is empty")
    if min(values) < 1:
        raise ValueError(f"{option} values must be >= 1, got {text!r}")
    return values


def name_list(text) -> tuple:
    """``"a, b"`` (or a sequence) -> ``('a', 'b')``.

    >>> name_list("uniform, mis")
    ('uniform', 'mis')
    """
    if isinstance(text, (list, tuple)):
        return tuple(str(s).strip() for s in text if str(s).strip())
    return tuple(s.strip() for s in str(text).split(",") if s.strip())


class ListAction(argparse.Action):
    """Comma-separated names, the option also repeatable: the first use replaces the default, later ones extend."""

    def __call__(self, parser, namespace, values, option_string=None):
        current = getattr(namespace, self.dest, None)
        untouched = current is None or current is self.default or current is parser.get_default(self.dest)
        current = () if untouched else tuple(current)
        setattr(namespace, self.dest, current + name_list(values))


#: dest -> (option, smallest value) of the integer options :func:`check` range-checks.
_MINIMUM = {"width": ("--width", 1), "height": ("--height", 1), "spp": ("--spp", 1), "seed": ("--seed", 0),
            "seeds": ("--seeds", 1), "threads": ("--threads", 1), "reference_spp": ("--reference-spp", 1),
            "tail_spp": ("--tail-spp", 0), "repeats": ("--repeats", 1), "batches": ("--batches", 1),
            "ray_count": ("--ray-count", 1), "scaling_spp": ("--scaling-spp", 1), "samples": ("--samples", 1)}
_INT_LISTS = {"spps": "--spps", "triangles": "--triangles", "resolutions": "--resolutions",
              "scaling_triangles": "--scaling-triangles"}


def check(args):
    """Range-check and normalise the shared options of ``args`` in place; ``ValueError`` (exit 2) on bad input.

    Integer lists become tuples, ``--variant`` a tuple of names; returns ``args``.

    >>> import argparse
    >>> check(argparse.Namespace(spps="1,4", alpha=0.01, width=8)).spps
    (1, 4)
    >>> check(argparse.Namespace(width=0))
    Traceback (most recent call last):
    ...
    ValueError: --width must be >= 1, got 0
    """
    for dest, (option, low) in _MINIMUM.items():
        v = getattr(args, dest, None)
        if v is not None and not isinstance(v, bool) and v < low:
            raise ValueError(f"{option} must be >= {low}, got {v}")
    for dest, option in _INT_LISTS.items():
        if getattr(args, dest, None) is not None:
            setattr(args, dest, int_list(getattr(args, dest), option=option))
    alpha = getattr(args, "alpha", None)
    if alpha is not None and not 0 < alpha < 1:
        raise ValueError(f"--alpha must be in (0, 1), got {alpha:g}")
    if getattr(args, "variant", None) is not None:
        args.variant = name_list(args.variant)
    if getattr(args, "format", None) is not None:
        args.format = formats(args.format)
    if getattr(args, "metric", None) is not None:
        from benchmarks.metrics import require_metric

        require_metric(args.metric)  # FLIP without its package: a clear error before any work
    return args


# ----------------------------------------------------------------------------------------- what to render

def add_scene_args(parser, *, nargs: str = "+", what: str = "suite scene name(s)") -> None:
    """Positional ``SCENE`` names (``scenes``; see ``rtbench render --list``)."""
    kw = {"default": None} if nargs in ("*", "?") else {}
    parser.add_argument("scenes", nargs=nargs, metavar="SCENE", help=f"{what} (`rtbench render --list` lists them)",
                        **kw)


def add_size_args(parser, *, width: int | None) -> None:
    """``--width`` (default per command; None: the scene's own) and ``--height`` (default: the width)."""
    parser.add_argument("--width", type=int, default=width, metavar="PX",
                        help="image width in pixels" + (" (default: the scene's own)" if width is None else ""))
    parser.add_argument("--height", type=int, default=None, metavar="PX",
                        help="image height in pixels (default: the width)")


def resolve_height(args) -> int | None:
    """``args.height``, or the width when no height was given."""
    return args.width if args.height is None else args.height


def add_spp_args(parser, *, default: int | None) -> None:
    """``--spp N``: samples per pixel of each render."""
    parser.add_argument("--spp", type=int, default=default, metavar="N",
                        help="samples per pixel of each render")


def add_spps_arg(parser, *, default) -> None:
    """``--spps N[,N...]``: the budgets of a sweep, comma-separated."""
    parser.add_argument("--spps", default=",".join(map(str, default)), metavar="N[,N...]",
                        help="budgets (samples per pixel) of the renders, comma-separated")


def add_strategy_args(parser, *, default, none_means: str = "") -> None:
    """``--strategies S[,S...]``: our sampling strategies (comma-separated, or the option repeated).

    An empty ``default`` means the command chooses (``none_means`` says how).
    """
    from benchmarks.constants import STRATEGIES

    parser.add_argument("--strategies", action=ListAction, default=tuple(default),
                        metavar="S[,S...]",
                        help=f"our sampling strategies, comma-separated or repeated: {', '.join(STRATEGIES)}"
                             + ("" if default else f" (default: {none_means})"))


def add_variant_args(parser, *, default=None) -> None:
    """``--variant V[,V...]``: the Mitsuba variant(s)."""
    parser.add_argument("--variant", default=None if default is None else ",".join(default),
                        metavar="V[,V...]",
                        help="Mitsuba variant(s), comma-separated"
                             + (" (default: the fastest that works here)" if default is None else ""))


def single_variant(args) -> str | None:
    """The one Mitsuba variant of a command that renders with one (``--variant`` gave at most one)."""
    v = args.variant
    if not v:
        return None
    if len(v) > 1:
        raise ValueError(f"--variant: this command uses one Mitsuba variant, got {','.join(v)}")
    return v[0]


def add_seed_args(parser, *, default: int = 0) -> None:
    """``--seed S``: the base seed of the renders (each render derives its own from it)."""
    parser.add_argument("--seed", type=int, default=default, metavar="S",
                        help="base seed of the renders; each render derives its own from it")


def add_seeds_arg(parser, *, default: int) -> None:
    """``--seeds K``: independent renders (seeds) per configuration."""
    parser.add_argument("--seeds", type=int, default=default, metavar="K",
                        help="independent renders (seeds 0..K-1) per configuration")


def add_reference_spp_arg(parser, *, default: int | None, none_means: str = "") -> None:
    """``--reference-spp N`` (hidden alias ``--ref-spp``): samples per pixel of the Mitsuba references."""
    parser.add_argument("--reference-spp", type=int, default=default, metavar="N",
                        help="samples per pixel of the cached Mitsuba references, rendered into the cache when "
                             "missing" + (f" (default: {none_means})" if default is None else ""))
    parser.add_argument("--ref-spp", type=int, dest="reference_spp", help=argparse.SUPPRESS)


def add_tail_spp_arg(parser, *, default: int) -> None:
    """``--tail-spp N``: samples per pixel of the tail references (0: none)."""
    parser.add_argument("--tail-spp", type=int, default=default, metavar="N",
                        help="samples per pixel of the tail references: the estimator under test at a high "
                             "budget (ours: cached), whose variance and tail "
                             "shape make the verdicts valid for heavy-tailed strategies (0: none, the older rule)")


def tail_spp_warning(tail_spp: int, *, default: int) -> str | None:
    """The line a command prints when ``--tail-spp`` is below the budget its false-alarm
    rates were measured at (``benchmarks/STATISTICS.md``, "Known limits"), else None.

    A tail reference stands for the estimator's rare paths only where it samples them; at a
    lower budget it misses them as the render does, and heavy-tailed strategies fail falsely.

    Examples
    --------
    >>> tail_spp_warning(16384, default=16384) is None
    True
    >>> tail_spp_warning(1024, default=16384).split(":")[0]
    '--tail-spp 1024 is below 16384'
    """
    if tail_spp >= default:
        return None
    if tail_spp == 0:
        return ("--tail-spp 0 turns the tail references off: verdicts on heavy-tailed strategies "
                "(uniform, cosine) then rest on the render's own variance, too small where its rare "
                "paths were missed, and can fail falsely (benchmarks/STATISTICS.md)")
    return (f"--tail-spp {tail_spp} is below {default}: the false-alarm rates (benchmarks/STATISTICS.md) "
            f"were measured at {default}, the default; below it a tail reference misses the rare paths "
            f"of heavy-tailed strategies as the render does, and verdicts on them can fail falsely "
            f"(measured: uniform on glossy_plates at 64 spp fails 20 of 20 seeds with --tail-spp 1024, "
            f"1 of 20 with 4096, 0 of 100 with {default})")


# ----------------------------------------------------------------------------------------- how to run

def add_threads_args(parser) -> None:
    """``--threads N``: rendering threads, ours and Mitsuba's alike (default all cores)."""
    parser.add_argument("--threads", type=int, default=None, metavar="N",
                        help="rendering threads, ours and Mitsuba's alike (default: all cores)")


def resolve_threads(threads) -> int:
    """``--threads`` as a number: all cores when unset (:func:`reference_tracer.cpus.default_threads`)."""
    from reference_tracer.cpus import default_threads

    return int(threads) if threads else default_threads()


def add_cache_arg(parser) -> None:
    """``--cache DIR``: the reference cache root."""
    parser.add_argument("--cache", default=None, metavar="DIR",
                        help="reference cache root (default: $RTBENCH_CACHE or ~/.cache/rtbench)")


def add_alpha_args(parser, *, default: float = DEFAULT_ALPHA) -> None:
    """``--alpha A``: the false-alarm rate of the whole run (see the module docstring)."""
    parser.add_argument("--alpha", type=float, default=default, metavar="A",
                        help="false-alarm rate of the whole run: the chance that any of its k tests fails on a "
                             "correct renderer; each test runs at about A/k")


def add_scheduler_arg(parser) -> None:
    """``--scheduler ADDRESS``: a Dask distributed scheduler for the sweep's jobs."""
    parser.add_argument("--scheduler", metavar="ADDRESS", default=None,
                        help="Dask distributed scheduler (e.g. tcp://host:8786), one job per worker "
                             "(default: run here)")


# ----------------------------------------------------------------------------------------- what to write

def add_renderer_arg(parser) -> None:
    """``--renderer CMD``: an external renderer (docs/rtbench.md: External renderers), repeatable."""
    parser.add_argument("--renderer", action="append", default=[], metavar="CMD",
                        help="an external renderer (repeatable where a command takes several; default: none): a "
                             "command template with {scene_xml} {spp} {seed} {width} {height} {out} that renders "
                             "the Mitsuba XML to an EXR at {out}, e.g. 'mitsuba -m scalar_rgb -D spp={spp} "
                             "-D seed={seed} -o {out} {scene_xml}' (docs/rtbench.md: External renderers)")


def add_quiet_arg(parser) -> None:
    """``--quiet``: no progress and no tables, only the final lines."""
    parser.add_argument("--quiet", action="store_true",
                        help="no progress output and no tables: only the final lines (files written, verdict)")


def add_out_arg(parser, *, default: str) -> None:
    """``--out DIR``: the command's output folder (its default is per command)."""
    parser.add_argument("--out", metavar="DIR", default=default, help="output folder (created if needed)")


def add_json_arg(parser) -> None:
    """``--json PATH``: also write the results as JSON."""
    parser.add_argument("--json", metavar="PATH", default=None,
                        help="also write every result row as JSON to PATH (default: none)")


def add_list_arg(parser) -> None:
    """``--list``: list what the command can run and exit."""
    parser.add_argument("--list", action="store_true",
                        help="list what this command can run (scenes, routines or mutants) and exit")


def add_metric_arg(parser) -> None:
    """``--metric``: the error metric of slopes, efficiency and time to target."""
    parser.add_argument("--metric", choices=METRICS, default=DEFAULT_METRIC,
                        help="error metric of the convergence slopes, efficiency and time to target: rmse, relmse "
                             "(relative MSE, the convention of rendering papers), ssim (as 1 - SSIM) or flip "
                             "(NVIDIA's FLIP)")


def formats(text) -> tuple:
    """``--format``'s value as a tuple of known formats; ``ValueError`` on an unknown one.

    >>> formats("html, csv")
    ('html', 'csv')
    """
    names = name_list(text)
    bad = [n for n in names if n not in FORMATS]
    if bad or not names:
        raise ValueError(f"--format: unknown format(s) {', '.join(bad) or '(none)'}; choose from "
                         f"{', '.join(FORMATS)}")
    return names


def add_format_arg(parser) -> None:
    """``--format html,svg,pdf,csv``: what the report writes."""
    parser.add_argument("--format", default="html", metavar="F[,F...]",
                        help="report outputs, comma-separated: html (index.html + summary.md), svg and pdf (every "
                             "plot as a vector file, named by scene and metric), csv (every curve point and the "
                             "summary, tidy)")
