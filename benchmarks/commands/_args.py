"""The one vocabulary of ``rtbench``'s options (docs/rtbench.md, Options: one name, one meaning), and the
checks and consoles the commands share; a subcommand chooses its own default only for :data:`PER_COMMAND_DEFAULTS`.

>>> p = argparse.ArgumentParser(formatter_class=HelpFormatter)
>>> add_size_args(p, width=32)
>>> a = check(p.parse_args(["--width", "48"]))
>>> a.width, a.height
(48, 48)
"""
from __future__ import annotations

import argparse
import re
import sys

from benchmarks.constants import GATE_ALPHA, STRATEGIES

#: options whose default a subcommand chooses (name, meaning and help text are still shared).
PER_COMMAND_DEFAULTS = frozenset({
    "--spp", "--spps", "--width", "--seed", "--seeds", "--out", "--reference-spp", "--strategies", "--variant",
})
#: the error metrics ``--metric`` chooses from; relMSE, the convention of rendering papers, by default.
METRICS = ("rmse", "relmse", "ssim", "flip")
DEFAULT_METRIC = "relmse"
#: what ``rtbench report --format`` can write.
FORMATS = ("html", "svg", "pdf", "csv")

_DEFAULT_CLAUSE = re.compile(r"\s*\(default:? [^()]*(\([^()]*\)[^()]*)*\)\s*$")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Appends ``(default: X)`` to an option's help, unless the default is None, False or
    suppressed (the help then says what happens without it) or the help names it already."""

    def _get_help_string(self, action):
        text = action.help or ""
        d = action.default
        if (d is None or d is False or d is argparse.SUPPRESS or (isinstance(d, tuple) and not d)
                or "%(default)" in text or "(default" in text
                or not action.option_strings and action.nargs not in ("?", "*")):
            return text
        if isinstance(d, (list, tuple)):
            return text + " (default: " + ",".join(map(str, d)).replace("%", "%%") + ")"
        return text + " (default: %(default)s)"


def base_help(text: str) -> str:
    """An option's help without its trailing ``(default ...)`` clause.

    >>> base_help("image height in pixels (default: the width)")
    'image height in pixels'
    """
    return _DEFAULT_CLAUSE.sub("", text or "")


def comma_list(text, *, option: str, item=None) -> tuple:
    """The one parser of every comma-separated list option: ``"a, b"`` (or a sequence) -> ``('a', 'b')``,
    blanks around and between commas dropped, each value converted by ``item`` (a ``ValueError`` of it
    propagates). An empty list (``""``, ``","``) is refused with a ``ValueError`` naming ``option``: an
    explicitly empty list is a mistake, never "all" or "none".

    >>> comma_list(" a, ,b", option="--x")
    ('a', 'b')
    >>> comma_list("", option="--strategies")
    Traceback (most recent call last):
    ...
    ValueError: --strategies is an empty list: give at least one value
    """
    parts = text if isinstance(text, (list, tuple)) else str(text).split(",")
    values = tuple(s for s in (str(p).strip() for p in parts) if s)
    if not values:
        raise ValueError(f"{option} is an empty list: give at least one value")
    return values if item is None else tuple(item(v) for v in values)


def int_list(text, *, option: str = "value") -> tuple:
    """``"1,2,4"`` (or a sequence) -> ``(1, 2, 4)``, every value >= 1 (:func:`comma_list`); ``ValueError``
    naming ``option``.

    >>> int_list("1, 2,4")
    (1, 2, 4)
    """
    if isinstance(text, (list, tuple)):
        text = ",".join(map(str, text))
    names = comma_list(text, option=option)
    try:
        values = tuple(int(v) for v in names)
    except ValueError:
        raise ValueError(f"{option} must be comma-separated integers, got {text!r}") from None
    if min(values) < 1:
        raise ValueError(f"{option} values must be >= 1, got {text!r}")
    return values


def name_list(text, *, option: str = "value") -> tuple:
    """``"a, b"`` (or a sequence) -> ``('a', 'b')`` (:func:`comma_list`); an empty list is a ``ValueError``.

    >>> name_list("uniform, mis")
    ('uniform', 'mis')
    """
    return comma_list(text, option=option)


class ListAction(argparse.Action):
    """Comma-separated values (:func:`comma_list`, each converted by ``item=``), the option also repeatable:
    the first use replaces the default, later ones extend; an empty list is a usage error naming the option."""

    def __init__(self, option_strings, dest, *, item=None, **kwargs):
        self.item = item
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        try:
            new = comma_list(values, option=option_string or self.dest, item=self.item)
        except ValueError as exc:  # argparse's usage error: `rtbench COMMAND: error: ...`, exit 2
            raise argparse.ArgumentError(None, str(exc)) from None
        current = getattr(namespace, self.dest, None)
        untouched = current is None or current is self.default or current is parser.get_default(self.dest)
        setattr(namespace, self.dest, (() if untouched else tuple(current)) + new)


#: dest -> smallest value of the integer options :func:`check` range-checks (the option is ``--dest``).
_MINIMUM = {"width": 1, "height": 1, "spp": 1, "seed": 0, "seeds": 1, "threads": 1, "reference_spp": 1, "tail_spp": 0,
            "repeats": 1, "batches": 1, "ray_count": 1, "scaling_spp": 1, "samples": 1}
_INT_LISTS = ("spps", "triangles", "resolutions", "scaling_depths", "scaling_triangles")


def check(args):
    """Range-check and normalise the shared options of ``args`` in place (integer lists, ``--variant`` and
    ``--format`` become tuples, :func:`comma_list` refusing an empty one; ``--height`` defaults to ``--width``);
    ``ValueError`` (exit 2) on bad input. Returns ``args``.

    >>> check(argparse.Namespace(width=0))
    Traceback (most recent call last):
    ...
    ValueError: --width must be >= 1, got 0
    """
    for dest, low in _MINIMUM.items():
        v = getattr(args, dest, None)
        if v is not None and not isinstance(v, bool) and v < low:
            raise ValueError(f"--{dest.replace('_', '-')} must be >= {low}, got {v}")
    for dest in _INT_LISTS:
        if getattr(args, dest, None) is not None:
            setattr(args, dest, int_list(getattr(args, dest), option=f"--{dest.replace('_', '-')}"))
    ladder = getattr(args, "spp_ladder", None)
    if isinstance(ladder, str):  # selftest's budgets below --spp: 'none' is none, an empty list a mistake
        args.spp_ladder = () if ladder.strip().lower() == "none" else int_list(ladder, option="--spp-ladder")
    if getattr(args, "height", None) is not None and getattr(args, "width", 0) is None:
        raise ValueError("--height needs --width")
    if getattr(args, "height", 0) is None:
        args.height = args.width
    alpha = getattr(args, "alpha", None)
    if alpha is not None and not 0 < alpha < 1:
        raise ValueError(f"--alpha must be in (0, 1), got {alpha:g}")
    if getattr(args, "variant", None) is not None:
        args.variant = name_list(args.variant, option="--variant")
    if getattr(args, "format", None) is not None:
        args.format = name_list(args.format, option="--format")
        bad = [n for n in args.format if n not in FORMATS]
        if bad:
            raise ValueError(f"--format: unknown format(s) {', '.join(bad)}; choose from {', '.join(FORMATS)}")
    if getattr(args, "metric", None) is not None:
        from benchmarks.metrics import require_metric

        require_metric(args.metric)  # FLIP without its package: a clear error before any work
    return args


def _option(*names, **spec):
    """An ``add_*(parser, **override)`` that adds one option of the vocabulary (``spec``: argparse's keywords)."""
    def add(parser, **override):
        parser.add_argument(*names, **{**spec, **override})
    return add


add_spp_args = _option("--spp", type=int, metavar="N", help="samples per pixel of each render")
add_seed_args = _option("--seed", type=int, default=0, metavar="S",
                        help="base seed of the renders; each render derives its own from it")
add_seeds_arg = _option("--seeds", type=int, metavar="K", help="independent renders (seeds 0..K-1) per configuration")
add_tail_spp_arg = _option("--tail-spp", type=int, metavar="N",
                           help="samples per pixel of the tail references: the estimator under test at a high "
                                "budget (ours: cached), whose variance and tail shape make the verdicts valid for "
                                "heavy-tailed strategies (0: none, the older rule)")
add_threads_args = _option("--threads", type=int, default=None, metavar="N",
                           help="rendering threads, ours and Mitsuba's alike (default: all cores)")
add_cache_arg = _option("--cache", default=None, metavar="DIR",
                        help="reference cache root (default: $RTBENCH_CACHE or ~/.cache/rtbench)")
add_alpha_args = _option("--alpha", type=float, default=GATE_ALPHA, metavar="A",
                         help="false-alarm rate of the whole run: the chance that any of its k tests fails on a "
                              "correct renderer; each test runs at about A/k")
add_scheduler_arg = _option("--scheduler", metavar="ADDRESS", default=None,
                            help="Dask distributed scheduler (e.g. tcp://host:8786), one job per worker "
                                 "(default: run here)")
add_renderer_arg = _option("--renderer", action="append", default=[], metavar="CMD",
                           help="an external renderer (repeatable where a command takes several; default: none): a "
                                "command template with {scene_xml} {spp} {seed} {width} {height} {out} that renders "
                                "the Mitsuba XML to an EXR at {out}, e.g. 'mitsuba -m scalar_rgb -D spp={spp} "
                                "-D seed={seed} -o {out} {scene_xml}' (docs/rtbench.md: External renderers)")
add_quiet_arg = _option("--quiet", action="store_true",
                        help="no progress output and no tables: only the final lines (files written, verdict)")
add_out_arg = _option("--out", metavar="DIR", help="output folder (created if needed)")
add_json_arg = _option("--json", metavar="PATH", default=None,
                       help="also write every result row as JSON to PATH, strict JSON: an undefined or infinite "
                            "number (NaN, inf) is null (default: none)")
add_list_arg = _option("--list", action="store_true",
                       help="list what this command can run (scenes, routines or mutants) and exit")
add_metric_arg = _option("--metric", choices=METRICS, default=DEFAULT_METRIC,
                         help="error metric of the convergence slopes, efficiency and time to target: rmse, relmse "
                              "(relative MSE, the convention of rendering papers), ssim (as 1 - SSIM) or flip "
                              "(NVIDIA's FLIP)")
add_format_arg = _option("--format", default="html", metavar="F[,F...]",
                         help="report outputs, comma-separated: html (index.html + summary.md), svg and pdf (every "
                              "plot as a vector file, named by scene and metric), csv (every curve point and the "
                              "summary, tidy)")


def add_scene_args(parser, *, nargs: str = "*", what: str = "suite scene name(s)") -> None:
    """Positional ``SCENE`` names (``scenes``, None when none is given)."""
    parser.add_argument("scenes", nargs=nargs, default=None, metavar="SCENE",
                        help=f"{what} (`rtbench render --list` lists them)")


def add_size_args(parser, *, width: int | None, default_help: str | None = None) -> None:
    """``--width`` (None: the scene's own, or what ``default_help`` says) and ``--height`` (default: the width)."""
    if default_help is None and width is None:
        default_help = "the scene's own"
    parser.add_argument("--width", type=int, default=width, metavar="PX",
                        help="image width in pixels" + (f" (default: {default_help})" if default_help else ""))
    parser.add_argument("--height", type=int, default=None, metavar="PX",
                        help="image height in pixels (default: the width)")


def add_spps_arg(parser, *, default) -> None:
    """``--spps N[,N...]``: the budgets of a sweep."""
    parser.add_argument("--spps", default=",".join(map(str, default)), metavar="N[,N...]",
                        help="budgets (samples per pixel) of the renders, comma-separated")


def add_strategy_args(parser, *, default, none_means: str = "") -> None:
    """``--strategies S[,S...]``; an empty ``default`` means the command chooses (``none_means`` says how)."""
    parser.add_argument("--strategies", action=ListAction, default=tuple(default), metavar="S[,S...]",
                        help=f"our sampling strategies, comma-separated or repeated: {', '.join(STRATEGIES)}"
                             + ("" if default else f" (default: {none_means})"))


def add_variant_args(parser, *, default=None) -> None:
    """``--variant V[,V...]``: the Mitsuba variant(s)."""
    parser.add_argument("--variant", default=None if default is None else ",".join(default), metavar="V[,V...]",
                        help="Mitsuba variant(s), comma-separated"
                             + (" (default: the fastest that works here)" if default is None else ""))


def single_variant(args) -> str | None:
    """The one Mitsuba variant of a command that renders with one (``--variant`` gave at most one)."""
    if args.variant and len(args.variant) > 1:
        raise ValueError(f"--variant: this command uses one Mitsuba variant, got {','.join(args.variant)}")
    return args.variant[0] if args.variant else None


def add_reference_spp_arg(parser, *, default: int | None, none_means: str = "") -> None:
    """``--reference-spp N`` (hidden alias ``--ref-spp``)."""
    parser.add_argument("--reference-spp", type=int, default=default, metavar="N",
                        help="samples per pixel of the cached Mitsuba references, rendered into the cache when "
                             "missing" + (f" (default: {none_means})" if default is None else ""))
    parser.add_argument("--ref-spp", type=int, dest="reference_spp", help=argparse.SUPPRESS)


def warn_tail_spp(command: str, tail_spp: int) -> None:
    """Warn on stderr where ``--tail-spp`` is below the budget of the measured false-alarm rates.

    >>> import contextlib, io
    >>> with contextlib.redirect_stderr(io.StringIO()) as err:
    ...     warn_tail_spp("gate", 1024)
    >>> err.getvalue().split(":")[:3]
    ['rtbench gate', ' warning', ' --tail-spp 1024 is below 16384']
    """
    from benchmarks.tails import DEFAULT_TAIL_SPP as default

    if tail_spp >= default:
        return
    if tail_spp == 0:
        line = ("--tail-spp 0 turns the tail references off: verdicts on heavy-tailed strategies "
                "(uniform, cosine) then rest on the render's own variance, too small where its rare "
                "paths were missed, and can fail falsely (benchmarks/STATISTICS.md)")
    else:
        line = (f"--tail-spp {tail_spp} is below {default}: the false-alarm rates (benchmarks/STATISTICS.md) "
                f"were measured at {default}, the default; below it a tail reference misses the rare paths "
                f"of heavy-tailed strategies as the render does, and verdicts on them can fail falsely "
                f"(measured: uniform on glossy_plates at 64 spp fails 20 of 20 seeds with --tail-spp 1024, "
                f"1 of 20 with 4096, 0 of 100 with {default})")
    print(f"rtbench {command}: warning: {line}", file=sys.stderr)


def stderr_log(args):
    """``log(line)`` onto stderr (flushed), None with ``--quiet``."""
    return None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))


def resolve_threads(threads) -> int:
    """``--threads`` as a number: all cores when unset."""
    from reference_tracer.cpus import default_threads

    return int(threads) if threads else default_threads()


def add_scene_path_args(parser) -> None:
    """``--scene PATH`` and ``--param NAME=VALUE`` (both repeatable): user scenes beside the suite's, registered
    (:mod:`mitsuba_scenes.scene_files`) and then accepted wherever a suite name is."""
    group = parser.add_argument_group("scene files")
    group.add_argument("--scene", dest="scene_files", action="append", default=[], metavar="PATH",
                       help="a scene file, beside suite names (repeatable): a Mitsuba 3 XML file (imported "
                            "by from_mitsuba; unsupported features are refused with file:line) or a Python "
                            "file defining build(width, height) that returns a reference_tracer.Scene")
    group.add_argument("--param", dest="scene_params", action="append", default=[], metavar="NAME=VALUE",
                       help="a parameter of the scene files (repeatable): an XML $NAME value (overrides its "
                            "<default>) or a keyword argument of build(); with several files, each gets the "
                            "parameters it takes")


def resolve_scenes(args, *, suite_names=None, default=None, known=False, required=False) -> list:
    """Register ``args.scene_files``; return ``suite_names`` then the files' names without repeats
    (``default`` when there are neither). ``known``: refuse a suite name the suite lacks; ``required``: no scene."""
    from mitsuba_scenes import list_scenes
    from mitsuba_scenes.scene_files import params_used, parse_params, register_scene_file

    unknown = [s for s in suite_names or [] if s not in list_scenes()] if known else []
    if unknown:
        raise ValueError(f"unknown scene(s) {unknown}; the suite has: {', '.join(list_scenes())}")
    params = parse_params(args.scene_params)
    files = args.scene_files
    if params and not files:
        raise ValueError("--param applies to scene files: give one with --scene PATH")
    names = list(suite_names or [])
    used = set()
    for path in files:
        mine = params_used(path, params) if len(files) > 1 else params
        used.update(mine)
        names.append(register_scene_file(path, mine).name)
    unused = sorted(set(params) - used)
    if unused:
        raise ValueError(f"--param {', '.join(unused)}: no scene file takes it")
    if required and not names:
        raise ValueError("no scene: give suite scene names or --scene PATH")
    return list(dict.fromkeys(names or default or []))


def wide_console(width: int, *, soft_wrap: bool = False, quiet: bool = False):
    """A rich console on stdout, at least ``width`` wide where it is no terminal (logs and pipes:
    one table row per line; ``soft_wrap``: no line cut at all)."""
    from rich.console import Console

    console = Console(quiet=quiet)
    return console if console.is_terminal else Console(width=max(console.width, width), soft_wrap=soft_wrap,
                                                       quiet=quiet)


def progress_bar(args, label: str = "{task.description}", *, stderr: bool = True):
    """A transient rich progress bar (spinner, ``label``, bar, done/total, time), silent with ``--quiet``."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    return Progress(SpinnerColumn(), TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                    console=Console(stderr=stderr, quiet=args.quiet), transient=True)


def print_failed_jobs(failed, *, limit: int = 10) -> None:
    """The first ``limit`` of a sweep's failed jobs, ``  failed: LABEL: WHY`` each, on stderr (errors go there)."""
    for label, why in failed[:limit]:
        print(f"  failed: {label}: {why}", file=sys.stderr)
