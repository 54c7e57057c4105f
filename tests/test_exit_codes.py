"""Exit codes of ``rtbench`` (docs/rtbench.md, Exit status and errors): 0 pass, 1 a verdict
failed, 2 usage or bad input, 3 internal or I/O error; one line on stderr for 2 and 3, the
traceback only with ``--debug``. Decided once, in ``benchmarks.cli`` (issue 15, case 8)."""
from __future__ import annotations

import errno

import pytest

from benchmarks import cli
from benchmarks.errors import EXIT_CODES_HELP, InputError, exit_code, one_line


def _err_lines(capsys) -> list:
    return [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]


def _one_error_line(capsys, command: str) -> str:
    lines = _err_lines(capsys)
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"rtbench {command}: error: "), lines
    assert "Traceback" not in lines[0]
    return lines[0]


@pytest.mark.parametrize("option", ["--spp", "--width", "--threads", "--height"])
def test_integers_beyond_the_core_int_are_usage_errors(option, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["render", "cornell_box", "--width", "4", option, str(2**31)])
    assert exc.value.code == 2
    lines = _err_lines(capsys)
    assert len(lines) == 1 and lines[0].startswith("rtbench render: error: argument") and "too large" in lines[0]


def test_library_refuses_counts_beyond_the_core_int():
    import reference_tracer as rt
    from mitsuba_scenes import get_scene

    scene = get_scene("cornell_box", width=2, height=2)
    with pytest.raises(ValueError, match="spp must be <= 2147483647"):
        rt.render(scene, spp=3_000_000_000)
    with pytest.raises(ValueError, match="threads must be <= 2147483647"):
        rt.render(scene, spp=1, threads=2**31)
    with pytest.raises(ValueError, match="Camera.width must be <= 2147483647"):
        get_scene("cornell_box", width=2**31, height=2)


def test_exposure_overflow_is_a_usage_error(tmp_path, capsys):
    code = cli.main(["render", "cornell_box", "--width", "2", "--spp", "1", "--exposure", "2000",
                     "--out", str(tmp_path)])
    assert code == 2
    assert "exposure" in _one_error_line(capsys, "render")


def test_output_path_that_is_a_file_is_an_io_error(tmp_path, capsys):
    f = tmp_path / "FILE"
    f.write_text("x")
    code = cli.main(["render", "cornell_box", "--width", "2", "--spp", "1", "--out", str(f)])
    assert code == 3
    line = _one_error_line(capsys, "render")
    assert str(f) in line and "a folder was expected" in line


def test_unwritable_json_path_is_an_io_error(tmp_path, capsys):
    code = cli.main(["chi2", "--routine", "warp.cosine", "--samples", "2000", "--images", "none",
                     "--json", "/proc/rtbench-no-such-file"])
    assert code == 3
    assert "/proc/rtbench-no-such-file" in _one_error_line(capsys, "chi2")


@pytest.mark.parametrize("command", [["gate", "cornell_box"], ["stress", "--quick"], ["selftest"]])
def test_unwritable_output_file_fails_before_the_run(command, capsys, monkeypatch):
    import importlib

    module = importlib.import_module(f"benchmarks.commands.{command[0]}")
    monkeypatch.setattr(module, "run", lambda args: pytest.fail("ran before checking its output file"))
    assert cli.main([*command, "--json", "/proc/rtbench-no-such-file"]) == 3
    assert "/proc/rtbench-no-such-file" in _one_error_line(capsys, command[0])


@pytest.mark.parametrize("option", ["--json", "--markdown"])
def test_a_dash_for_an_output_file_is_refused_before_the_run(tmp_path, capsys, monkeypatch, option):
    """`--json -` names no file: refused before the run (exit 2, naming the option), where it
    once wrote a file called '-' in the working folder."""
    import benchmarks.commands.selftest as selftest

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(selftest, "run", lambda args: pytest.fail("ran before checking its output file"))
    assert cli.main(["selftest", option, "-"]) == 2
    assert f"{option} -: these outputs go to files, not to standard output" in _one_error_line(capsys, "selftest")
    assert not (tmp_path / "-").exists()


@pytest.mark.parametrize("kind", ["fifo", "link"])
def test_an_output_path_that_is_no_regular_file_is_refused_and_left_as_it_is(tmp_path, capsys, monkeypatch, kind):
    """--json on a FIFO or a symbolic link is refused before the run (exit 2, naming the option),
    as the atomic write at the end would refuse it, and left as it was: the FIFO is not opened
    (an open for appending blocks until a reader comes), no file is made through the link and
    the link stays."""
    import os
    import stat

    import benchmarks.commands.gate as gate

    monkeypatch.setattr(gate, "run", lambda args: pytest.fail("ran before checking its output file"))
    path, target = tmp_path / "out.json", tmp_path / "target.json"
    reader = None
    if kind == "fifo":
        os.mkfifo(path)
        reader = os.open(path, os.O_RDONLY | os.O_NONBLOCK)   # so that an open of it cannot hang the test
    else:
        path.symlink_to(target)
    try:
        assert cli.main(["gate", "cornell_box", "--json", str(path)]) == 2
    finally:
        if reader is not None:
            os.close(reader)
    what = "a special file" if kind == "fifo" else "a symbolic link"
    assert f"--json: {path} is {what}; refusing to replace it" in _one_error_line(capsys, "gate")
    mode = os.lstat(path).st_mode
    assert (stat.S_ISFIFO(mode) if kind == "fifo" else stat.S_ISLNK(mode)) and not target.exists()


def test_an_unwritable_svg_path_fails_before_the_scaling_run(capsys, monkeypatch):
    """rtbench speed --scaling --svg PATH: an unwritable PATH is an I/O error (exit 3) before the
    scaling benchmark runs, not after it, with the option named."""
    import benchmarks.commands.speed as speed

    monkeypatch.setattr(speed, "run", lambda args: pytest.fail("ran before checking its output file"))
    assert cli.main(["speed", "--scaling", "--svg", "/proc/rtbench-no-such-file.svg"]) == 3
    line = _one_error_line(capsys, "speed")
    assert "--svg /proc/rtbench-no-such-file.svg cannot be written" in line, line


def test_debug_adds_the_traceback_before_or_after_the_command(tmp_path, capsys):
    f = tmp_path / "FILE"
    f.write_text("x")
    args = ["render", "cornell_box", "--width", "2", "--spp", "1", "--out", str(f)]
    for argv in (["--debug", *args], [*args, "--debug"]):
        assert cli.main(argv) == 3
        err = capsys.readouterr().err
        assert "Traceback (most recent call last)" in err and err.rstrip().splitlines()[-1].startswith(
            "rtbench render: error:")


@pytest.mark.parametrize("exc, code, words", [
    (MemoryError(), 3, "out of memory"),
    (RuntimeError("boom"), 3, "internal error: RuntimeError: boom"),
    (OSError(errno.ENOSPC, "No space left on device", "/x/results.jsonl"), 3, "disk full"),
    (OverflowError("int too large to convert"), 2, "number out of range"),
    (InputError("not a store"), 2, "not a store"),
])
def test_exceptions_map_to_one_line_and_a_code(monkeypatch, capsys, exc, code, words):
    import benchmarks.commands.report as report

    def boom(args):
        raise exc

    monkeypatch.setattr(report, "run", boom)
    assert cli.main(["report", "somewhere"]) == code
    assert words in _one_error_line(capsys, "report")


@pytest.mark.parametrize("argv, unknown", [
    (["stress", "--bogus"], "--bogus"),
    (["parity", "--threads", "2"], "--threads"),        # parity has no --threads ('2' is a scene name)
    (["render", "cornell_box", "--spp", "1", "--nope"], "--nope"),
])
def test_an_unknown_option_is_the_subcommands_usage_error(argv, unknown, capsys):
    """argparse hands a subcommand's unknown arguments up to the top-level parser, which said
    `rtbench: error: ...`; the documented form names the command."""
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    line = _one_error_line(capsys, argv[0])
    assert f"unrecognized arguments: {unknown}" in line and f"`rtbench {argv[0]} --help`" in line


def test_an_unknown_top_level_option_stays_the_top_levels(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--bogus", "render"])
    assert exc.value.code == 2
    lines = _err_lines(capsys)
    assert len(lines) == 1 and lines[0].startswith("rtbench: error: unrecognized arguments: --bogus"), lines


def test_every_help_documents_the_exit_codes(capsys):
    for name in ("run", "render", "reference", "report", "gate", "stress", "chi2", "selftest", "speed", "curves"):
        with pytest.raises(SystemExit) as exc:
            cli.main([name, "--help"])
        assert exc.value.code == 0
        out = " ".join(capsys.readouterr().out.split())
        assert "exit status: 0 pass; 1 a verdict failed" in out and "--debug" in out, name


def test_error_helpers():
    assert exit_code(InputError("x")) == 2 and exit_code(KeyboardInterrupt()) == 130
    assert exit_code(PermissionError(errno.EACCES, "Permission denied")) == 3
    assert one_line(ValueError("a\n  b")) == "a b"
    assert "exit status" in EXIT_CODES_HELP
