"""The study runner (studies/run_study.py, the README's main command): stage selection."""

from pathlib import Path

import pytest

from tests.study_module import load_study

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture()
def runner(monkeypatch):
    module = load_study("run_study")
    ran, codes = [], {}

    class Stage:
        def __init__(self, script):
            self.script = script

        def main(self, flags):
            ran.append((self.script, tuple(flags)))
            return codes.get(self.script)

    monkeypatch.setattr(module, "_load", Stage)
    return module, ran, codes  # codes: a stage script's return value, by script (None: the stage returns nothing)


def test_only_selects_stages_by_script_or_name_in_study_order(runner):
    module, ran, _ = runner
    assert module.main(["--quick", "--only", "report.py", "calibration"]) == 0
    quick = ("--quick", "--out", str(ROOT / "figures" / "quick"))  # a quick run never writes over figures/
    assert ran == [("calibrate.py", quick), ("report.py", quick)]


def test_default_and_chosen_output_folders(runner, tmp_path):
    module, ran, _ = runner
    assert module.main(["--only", "report.py"]) == 0
    assert module.main(["--full", "--only", "report.py", "--out", str(tmp_path)]) == 0
    assert ran == [("report.py", ("--out", str(ROOT / "figures"))), ("report.py", ("--full", "--out", str(tmp_path)))]


def test_an_unknown_stage_is_refused_by_name(runner, capsys):
    module, ran, _ = runner
    with pytest.raises(SystemExit) as exc:
        module.main(["--only", "calib"])
    assert exc.value.code == 2 and ran == []
    err = capsys.readouterr().err
    assert "--only: expected stages among" in err and "'calibrate.py'" in err and "got ['calib']" in err


def test_a_stage_returning_a_nonzero_code_fails_the_study_and_the_others_still_run(runner, capsys):
    module, ran, codes = runner
    codes["evidence_check.py"] = 2  # the evidence check's exit on a record it cannot read
    assert module.main(["--only", "evidence check", "report"]) == 1
    assert [s for s, _ in ran] == ["evidence_check.py", "report.py"]
    err = capsys.readouterr().err
    assert "stage evidence check (evidence_check.py) failed (exit code 2)" in err
    assert "FAILED stages: evidence check" in err
    codes["evidence_check.py"] = 0
    assert module.main(["--only", "evidence check"]) == 0
