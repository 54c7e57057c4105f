"""One CLI vocabulary (issue 16): every shared option has one name, one default and one help text.

Walks the parser of every ``rtbench`` subcommand. Fast: nothing is rendered.
"""
from __future__ import annotations

import argparse
import collections

import pytest

from benchmarks.cli import build_parser, main
from benchmarks.commands import _args as A


def _subparsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _options():
    """option string -> [(command, action)] over every subcommand (hidden aliases left out)."""
    out = collections.defaultdict(list)
    for cmd, p in _subparsers().items():
        for action in p._actions:
            if action.help == argparse.SUPPRESS or isinstance(action, argparse._HelpAction):
                continue
            for opt in action.option_strings:
                out[opt].append((cmd, action))
    return out


SHARED = {opt: uses for opt, uses in _options().items() if len(uses) > 1}


def test_the_shared_options_are_the_ones_expected():
    # the vocabulary: each of these is defined once in benchmarks/commands/_args.py
    for opt in ("--width", "--height", "--spp", "--seed", "--threads", "--cache", "--alpha", "--out", "--quiet",
                "--strategies", "--variant", "--reference-spp", "--json", "--metric"):
        assert opt in SHARED, opt


@pytest.mark.parametrize("opt", sorted(SHARED))
def test_shared_option_has_one_name_meaning_default_and_help(opt):
    uses = SHARED[opt]
    first_cmd, first = uses[0]
    for cmd, a in uses[1:]:
        where = f"{opt}: {first_cmd} vs {cmd}"
        assert a.option_strings == first.option_strings, where
        assert a.dest == first.dest, where
        assert type(a) is type(first), where
        assert a.type is first.type and a.nargs == first.nargs and a.choices == first.choices, where
        assert a.metavar == first.metavar, where
        assert A.base_help(a.help) == A.base_help(first.help), where
        if opt not in A.PER_COMMAND_DEFAULTS:
            assert a.default == first.default, where


def test_every_default_is_visible_in_help():
    for cmd, p in _subparsers().items():
        text = p.format_help()
        for a in p._actions:
            if not a.option_strings or a.help == argparse.SUPPRESS or isinstance(a, argparse._HelpAction):
                continue
            if a.default is None or a.default is False or a.default == ():
                assert "default" in a.help or a.default is False, f"{cmd} {a.option_strings}: {a.help!r}"
            else:
                shown = ",".join(map(str, a.default)) if isinstance(a.default, (list, tuple)) else str(a.default)
                flat = " ".join(text.split()).replace("- ", "-")
                assert f"(default: {shown})" in flat or "(default" in a.help, f"{cmd} {a.option_strings}"


def test_every_subcommand_has_quiet_and_height_defaults_to_width():
    for cmd, p in _subparsers().items():
        opts = {o: a for a in p._actions for o in a.option_strings}
        assert "--quiet" in opts, cmd
        if "--height" in opts:
            assert opts["--height"].default is None and "the width" in opts["--height"].help, cmd
        if "--threads" in opts:
            assert opts["--threads"].default is None and "all cores" in opts["--threads"].help, cmd


def test_ref_spp_is_a_hidden_alias_of_reference_spp():
    p = _subparsers()["gate"]
    assert p.parse_args(["--ref-spp", "256"]).reference_spp == 256
    assert p.parse_args(["--reference-spp", "512"]).reference_spp == 512
    assert "--ref-spp" not in p.format_help()


def test_strategies_comma_separated_or_repeated():
    p = _subparsers()["render"]
    assert p.parse_args(["cornell_box"]).strategies == ("mis",)
    assert p.parse_args(["cornell_box", "--strategies", "uniform,light"]).strategies == ("uniform", "light")
    assert p.parse_args(["x", "--strategies", "uniform", "--strategies", "mis"]).strategies == ("uniform", "mis")
    assert p.parse_args(["x", "--strategy", "cosine"]).strategies == ("cosine",)  # the older name


def test_check_rejects_bad_values_in_one_line():
    with pytest.raises(ValueError, match="--threads must be >= 1"):
        A.check(argparse.Namespace(threads=0))
    with pytest.raises(ValueError, match="--spps must be comma-separated integers"):
        A.check(argparse.Namespace(spps="1,x"))
    with pytest.raises(ValueError, match=r"--alpha must be in \(0, 1\)"):
        A.check(argparse.Namespace(alpha=1.5))
    with pytest.raises(ValueError, match="unknown format"):
        A.check(argparse.Namespace(format="html,gif"))


def test_curves_alpha_is_the_whole_run_rate():
    from benchmarks.commands.curves import sweep_kwargs
    from benchmarks.sweep import Group

    args = _subparsers()["curves"].parse_args(["cornell_box", "furnace", "--alpha", "0.01"])
    g = Group(scenes=("cornell_box", "furnace"), strategies=("uniform", "mis"), spps=(1, 2), seeds=2, width=8,
              height=8, mitsuba=True)
    assert sweep_kwargs(args, [g])["alpha"] == pytest.approx(0.01 / 6)  # 2 scenes x (2 strategies + Mitsuba)


def test_run_scenes_announces_the_right_suite(capsys):
    from benchmarks.sweep.presets import describe_preset

    text = describe_preset("quick", scenes=["furnace"])
    assert "1 scene(s)" in text and "seed comparison" not in text


def test_default_output_folders_differ_per_run():
    from benchmarks.commands import curves, render, run

    assert curves.default_out(["cornell_box"], 32, 32) != curves.default_out(["cornell_box"], 48, 32)
    assert run.default_out("quick", ["furnace"]) != run.default_out("quick", None)
    names = {render.file_stem("cornell_box", 16, 16, s, spp, seed)
             for s in ("mis", "light") for spp in (1, 2) for seed in (0, 1)}
    assert len(names) == 8


def test_bad_option_value_is_exit_2(capsys):
    assert main(["render", "cornell_box", "--spp", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--spp must be >= 1" in err[0]


def test_render_names_every_setting_and_renders_mitsuba_on_request(tmp_path, capsys):
    args = ["render", "cornell_box", "--width", "8", "--spp", "2", "--strategies", "mis,light", "--threads", "1",
            "--out", str(tmp_path), "--quiet"]
    assert main(args) == 0
    assert main(args[:-1] + ["--seed", "1", "--quiet"]) == 0          # another seed: new files, none overwritten
    assert main(args + ["--mitsuba", "--variant", "scalar_rgb"]) == 0
    names = sorted(p.name for p in tmp_path.glob("*.exr"))
    assert names == ["cornell_box_8x8_light_spp2_seed0.exr", "cornell_box_8x8_light_spp2_seed1.exr",
                     "cornell_box_8x8_mis_spp2_seed0.exr", "cornell_box_8x8_mis_spp2_seed1.exr",
                     "cornell_box_8x8_mitsuba-scalar_rgb_spp2_seed0.exr"]
    assert "NaN/Inf" not in capsys.readouterr().out  # --quiet: only the 'wrote' lines


def _cgroup(tmp_path, member: str, limits: dict):
    """A fake cgroup v2 tree under tmp_path: ``limits`` maps a cgroup path to its cpu.max."""
    root = tmp_path / "cgroup"
    for rel, text in limits.items():
        folder = root / rel.strip("/")
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "cpu.max").write_text(text + "\n")
    (tmp_path / "membership").write_text(f"1:cpu:/\n0::{member}\n")
    return dict(root=root, membership=tmp_path / "membership")


def test_cgroup_cpu_limit_reads_the_smallest_quota_on_the_way_to_the_root(tmp_path):
    from reference_tracer.cpus import cgroup_cpu_limit

    assert cgroup_cpu_limit(**_cgroup(tmp_path / "a", "/", {"/": "max 100000"})) is None
    assert cgroup_cpu_limit(**_cgroup(tmp_path / "b", "/", {"/": "150000 100000"})) == 1.5
    nested = _cgroup(tmp_path / "c", "/job/step", {"/": "max 100000", "/job": "400000 100000",
                                                    "/job/step": "600000 100000"})
    assert cgroup_cpu_limit(**nested) == 4.0                  # the parent's quota caps the child's
    assert cgroup_cpu_limit(**_cgroup(tmp_path / "d", "/x", {"/": "garbage"})) is None
    assert cgroup_cpu_limit(root=tmp_path / "none", membership=tmp_path / "none") is None


def test_all_cores_respects_affinity_and_the_cgroup_quota(monkeypatch):
    from reference_tracer import cpus as jobs

    monkeypatch.setattr(jobs.os, "sched_getaffinity", lambda pid: {0, 1, 2, 3, 4, 5, 6, 7}, raising=False)
    monkeypatch.setattr(jobs, "cgroup_cpu_limit", lambda: None)
    assert jobs.default_threads() == 8
    monkeypatch.setattr(jobs, "cgroup_cpu_limit", lambda: 2.5)  # a container with --cpus 2.5
    assert jobs.default_threads() == 3
    monkeypatch.setattr(jobs, "cgroup_cpu_limit", lambda: 0.2)
    assert jobs.default_threads() == 1
    monkeypatch.setattr(jobs, "cgroup_cpu_limit", lambda: 16.0)  # a quota above the affinity mask
    assert jobs.default_threads() == 8
    assert A.resolve_threads(None) == 8 and A.resolve_threads(3) == 3


#: (command line, the list option it empties) for every comma-separated list option of every command:
#: ``test_every_list_option_is_checked_for_emptiness`` fails when an option is added without a row here.
EMPTY_LISTS = [
    (["render", "cornell_box", "--strategies", ""], "--strategies"),
    (["render", "cornell_box", "--strategy", ","], "--strategy"),
    (["render", "cornell_box", "--variant", ""], "--variant"),
    (["run", "--scenes", "", "--no-report"], "--scenes"),
    (["run", "--format", ""], "--format"),
    (["run", "--variant", " , "], "--variant"),
    (["curves", "cornell_box", "--strategies", ""], "--strategies"),
    (["curves", "cornell_box", "--spps", ""], "--spps"),
    (["curves", "cornell_box", "--spp", ","], "--spps"),
    (["curves", "cornell_box", "--variant", ""], "--variant"),
    (["reference", "cornell_box", "--variant", ""], "--variant"),
    (["report", "STORE", "--format", ""], "--format"),
    (["gate", "--strategies", ""], "--strategies"),
    (["gate", "--calibrate", "--spps", ""], "--spps"),
    (["gate", "--variant", ""], "--variant"),
    (["corpus", "DIR", "--variant", ""], "--variant"),
    (["speed", "--strategies", ""], "--strategies"),
    (["speed", "--integrators", ""], "--integrators"),
    (["speed", "--variant", ""], "--variant"),
    (["speed", "--variants", ""], "--variant"),
    (["speed", "--rr-depth", ""], "--rr-depth"),
    (["speed", "--rays", "--triangles", ""], "--triangles"),
    (["speed", "--scaling", "--resolutions", ""], "--resolutions"),
    (["speed", "--scaling", "--scaling-depths", ""], "--scaling-depths"),
    (["speed", "--scaling", "--scaling-triangles", ""], "--scaling-triangles"),
    (["selftest", "--mutants", ""], "--mutants"),
    (["selftest", "--spp-ladder", ""], "--spp-ladder"),
]


def _list_options():
    """(command, option string) of every comma-separated list option, hidden aliases included: a
    :class:`~benchmarks.commands._args.ListAction`, a ``X[,X...]`` metavar or an integer list of ``check``."""
    out = set()
    for cmd, p in _subparsers().items():
        for a in p._actions:
            if (isinstance(a, A.ListAction) or "[," in str(a.metavar or "") or a.dest in A._INT_LISTS
                    or a.dest == "variant"):
                out.update((cmd, o) for o in a.option_strings)
    return out


def test_every_list_option_is_checked_for_emptiness():
    tested = {(argv[0], next(a for a in argv if a.startswith("--") and a not in ("--rays", "--scaling",
                                                                                   "--calibrate", "--no-report")))
              for argv, _ in EMPTY_LISTS}
    assert _list_options() <= tested, sorted(_list_options() - tested)


@pytest.mark.parametrize("argv, option", EMPTY_LISTS, ids=[" ".join(a) for a, _ in EMPTY_LISTS])
def test_an_empty_list_is_a_usage_error_naming_the_option(argv, option, capsys, monkeypatch):
    """``--strategies ""`` rendered nothing and exited 0, ``run --scenes ""`` ran the whole suite:
    an explicitly empty list is refused (exit 2) before the command starts, in one line."""
    import importlib

    module = importlib.import_module(f"benchmarks.commands.{argv[0]}")
    monkeypatch.setattr(module, "run", lambda args: pytest.fail(f"{argv[0]} ran with an empty {option}"))
    try:
        code = main(argv)
    except SystemExit as exc:   # refused while parsing (ListAction)
        code = exc.code
    assert code == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith(f"rtbench {argv[0]}: error: {option} is an empty list"), err


def test_list_values_still_parse():
    parsers = _subparsers()
    assert parsers["run"].parse_args(["--scenes", "furnace, cornell_box", "--scenes", "small_light"]).scenes == (
        "furnace", "cornell_box", "small_light")
    assert parsers["run"].parse_args([]).scenes is None
    assert parsers["speed"].parse_args(["--rr-depth", "5,none"]).rr_depth == (5, None)
    assert parsers["selftest"].parse_args(["--mutants", "a,b", "--mutants", "c"]).mutants == ("a", "b", "c")
    assert A.check(parsers["gate"].parse_args(["--variant", "scalar_rgb"])).variant == ("scalar_rgb",)
    with pytest.raises(SystemExit):
        parsers["speed"].parse_args(["--rr-depth", "5,x"])


def test_selftest_spp_ladder_none_is_no_ladder(monkeypatch):
    import benchmarks.selftest

    seen = {}

    def fake_selftest(names, **kwargs):
        seen.update(kwargs)
        raise KeyboardInterrupt  # stop here: only the arguments matter

    monkeypatch.setattr(benchmarks.selftest, "run_selftest", fake_selftest)
    assert main(["selftest", "--spp-ladder", "none", "--quiet"]) == 130
    assert seen["spp_ladder"] == []
    assert main(["selftest", "--spp-ladder", "2,4", "--quiet"]) == 130
    assert seen["spp_ladder"] == [2, 4]


def test_render_without_a_scene_says_so_on_stderr(capsys):
    """It printed the suite and exited 2 with nothing on stderr."""
    assert main(["render"]) == 2
    out, err = capsys.readouterr()
    assert "cornell_box" in out                     # the suite, to choose from
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("rtbench render: error: no scene"), lines
    assert main(["render", "--list"]) == 0 and capsys.readouterr().err == ""


def test_render_refuses_a_bad_variant_before_rendering(tmp_path, capsys, monkeypatch):
    """``--variant foo --mitsuba`` rendered ours (and wrote its files) and only then refused the variant."""
    import reference_tracer as rt

    monkeypatch.setattr(rt, "render", lambda *a, **k: pytest.fail("rendered before checking --variant"))
    code = main(["render", "cornell_box", "--width", "8", "--spp", "1", "--mitsuba", "--variant", "foo",
                 "--out", str(tmp_path / "out"), "--quiet"])
    assert code == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith("rtbench render: error: Mitsuba variant") and "'foo'" in err[0]
    assert not (tmp_path / "out").exists()


def test_a_warning_is_one_line_naming_the_command(tmp_path, capsys):
    """A store's skipped lines (a Python warning) print as ``rtbench compare: warning: ...`` on one
    line of stderr, as errors do: not Python's two-line form with the warning call's source."""
    from report_store import make_store

    from benchmarks.cli import main

    stores = [make_store(tmp_path / name, scenes=("cornell_box",), strategies=("uniform",), spps=(1, 4, 16),
                         seeds=(0, 1), size=8, mitsuba=False) for name in ("a", "b")]
    results = stores[1] / "results.jsonl"
    lines = results.read_text().splitlines()
    results.write_text("\n".join(lines[:2] + ["{not json"] + lines[2:]) + "\n")
    assert main(["compare", str(stores[0]), str(stores[1]), "--out", str(tmp_path / "cmp"), "--quiet"]) in (0, 1)
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert any(line.startswith("rtbench compare: warning: ") and "line(s) skipped" in line for line in err), err
    assert not any("Warning:" in line or "warnings.warn" in line for line in err), err
