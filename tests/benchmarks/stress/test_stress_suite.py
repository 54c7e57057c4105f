"""Every render of every suite scene reports zero NaN/Inf samples (issue 8), and the
``rtbench stress`` command prints its table and exits non-zero on a failed case."""
import pytest

from benchmarks import stress
from benchmarks.cli import main


def test_every_suite_scene_every_strategy_zero_nonfinite():
    rec = stress.suite_nonfinite(width=16, spp=4, seed=0)
    print(rec.figure)
    bad = {k: v for k, v in rec.details["nonfinite"].items() if v}
    assert not bad
    assert rec.details["renders"] >= 5


def test_rtbench_stress_prints_the_table(capsys):
    assert main(["stress", "--quick", "--case", "suite_nonfinite", "--case", "light_sampling"]) == 0
    out = capsys.readouterr().out
    for word in ("case", "figure", "verdict", "suite_nonfinite", "light_sampling", "pass"):
        assert word in out


def test_rtbench_stress_fails_on_a_failed_case(monkeypatch, capsys, tmp_path):
    def broken(**_):
        return stress.StressRecord(case="broken", figure="1 leak [not markup]", passed=False, details={"leaks": 1})

    monkeypatch.setitem(stress.CASES, "suite_nonfinite", (broken, {}, {}))
    path = tmp_path / "out.json"
    assert main(["stress", "--quick", "--case", "suite_nonfinite", "--json", str(path)]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out and "[not markup]" in out   # figures are printed verbatim
    assert '"leaks": 1' in path.read_text()


def test_unknown_case_is_refused():
    with pytest.raises(ValueError):
        stress.run_cases(["nope"])
