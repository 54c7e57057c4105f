"""`rtbench --help` lists every subcommand (a '%' in a subcommand's one-line help once
crashed it: argparse %-formats help strings but not descriptions)."""
import pytest

from benchmarks.cli import main


def test_top_level_help_lists_every_subcommand(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for name in ("gate", "selftest", "chi2", "curves", "report"):
        assert name in out
    assert "90%" in out
