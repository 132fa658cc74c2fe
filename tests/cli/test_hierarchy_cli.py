"""``bayestissue hierarchy``: a small two-stage run end to end (quick settings), its resume and the design statement
for a group of one (bad specimens files: tests/cli/test_bad_inputs.py)."""

import re
import shutil
from pathlib import Path

import pytest

from bayestissue.cli import main

GROUPS = Path(__file__).resolve().parents[2] / "data" / "synthetic" / "tendon_groups"

SPECIMENS = """fit_config = "fit.toml"
parameters = ["k1_1", "beta1"]
reference_group = "fresh"

[population]
seed = 3

[[specimen]]
name = "fresh_1"
group = "fresh"
experiments = ["fresh_1.toml"]

[[specimen]]
name = "fresh_2"
group = "fresh"
experiments = ["fresh_2.toml"]

[[specimen]]
name = "incubated_1"
group = "incubated"
experiments = ["incubated_1.toml"]
"""


@pytest.fixture
def study(tmp_path):
    for name in ("fresh_1", "fresh_2", "incubated_1", "incubated_2"):
        for ext in (".toml", ".csv"):
            shutil.copy(GROUPS / f"{name}{ext}", tmp_path / f"{name}{ext}")
    shutil.copy(GROUPS / "fit.toml", tmp_path / "fit.toml")
    (tmp_path / "specimens.toml").write_text(SPECIMENS)
    return tmp_path


def test_quick_run_and_resume(study, capsys):
    out = study / "run"
    argv = ["hierarchy", str(study / "specimens.toml"), "--out", str(out), "--quick", "--no-progress"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "group 'incubated' has one specimen: its effect is confounded" in text
    for f in ("hierarchy_summary.md", "hierarchy_summary.csv", "hierarchy.nc", "hierarchy.png"):
        assert (out / f).is_file(), f
    for name in ("fresh_1", "fresh_2", "incubated_1"):
        assert (out / "specimens" / name / "posterior.nc").is_file()
    first = (out / "hierarchy_summary.md").read_text()
    assert re.search(r"\| incubated vs fresh \| k1_1 \| ratio [0-9.]+ \| \[[0-9.]+, [0-9.]+\] \| 0\.\d\d \| 1 vs 2 \|",
                     first), first  # fmt: skip
    # resume: every specimen read back (no fit), the same stage 2 (same seed, same draws)
    assert main([*argv, "--resume"]) == 0
    text = capsys.readouterr().out
    assert text.count("finished before, read back") == 3, text
    assert (out / "hierarchy_summary.md").read_text() == first
    assert "## Groups in a tissue's terms" in first and "- priors: k1_1 (ln): m ~ N(" in first
    assert re.search(r"\| incubated vs fresh \| secant modulus \(instantaneous\) \| ratio [0-9.]+ \[", first), first
    # stage 1 as tasks of a dask cluster: the runs read back on its worker, the same answer
    assert main([*argv, "--resume", "--workers", "1"]) == 0
    assert capsys.readouterr().out.count("finished before, read back") == 3
    assert (out / "hierarchy_summary.md").read_text() == first
    # a task's refusal (an existing run, neither --resume nor --overwrite) comes back from the worker as one line
    assert main([*argv, "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--resume continues that run, --overwrite replaces it" in err[0], err
