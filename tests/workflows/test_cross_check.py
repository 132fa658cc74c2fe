"""``[sampler] cross_check = "nested"``: after the emcee engine a nested run of the same posterior is compared with
it, the comparison is in the verdict, the summary and ``cross_check.md``, and a killed check resumes from its own
checkpoints (bayestissue.workflows.calibration)."""

import numpy as np
import pytest

from bayestissue.workflows import load_config, run_calibration
from bayestissue.workflows.calibration import _every
from tests.short_creep import short_creep, short_creep_config


def _config(**over):
    return short_creep_config(
        n_starts=2,
        cross_check="nested",
        sampler={"n_ensembles": 2, "n_processes": 1, "max_steps": 1500, "prune_rounds": 1},
        nested={"n_live": 200, "n_eff": 1000, "n_runs": 2, "n_networks": 1, "n_processes": 1},
        n_predictive=10,
        **over,
    )


@pytest.mark.slow
def test_a_fit_is_cross_checked_by_a_nested_run(tmp_path):
    lines = []
    out = run_calibration([short_creep()], _config(), out_dir=tmp_path, say=lines.append)
    check = out.report.engine_check
    assert check is not None and check.names == ("mu", "ginf2")
    assert check.agree, check.text()  # one posterior, two engines: the quantiles agree within the limits
    assert np.max(check.rel) < 0.1, check.markdown()
    start = next(i for i, line in enumerate(lines) if "cross-check: 2 nested run(s)" in line)
    assert lines[-1] == check.text()
    assert all(line.startswith("cross-check: ") and " evaluations; run 0 " in line for line in lines[start + 1 : -1])
    assert check.text() in out.report.verdict() and out.report.verdict() in out.table["meta"]["convergence"]
    assert out.times_s["cross_check"] > 0
    md = (tmp_path / "cross_check.md").read_text()
    assert md.count("| mu |") == 1 and md.count("| ginf2 |") == 1
    assert sorted(p.name for p in (tmp_path / "checkpoints" / "cross_check").iterdir()) == [
        "nested_0.cost.json",  # each run's cost ledger beside its checkpoint
        "nested_0.h5",
        "nested_1.cost.json",
        "nested_1.h5",
    ]
    # the check's runs resume from their checkpoints: same seed, same check
    again = run_calibration([short_creep()], _config(), out_dir=tmp_path, resume=True)
    np.testing.assert_allclose(again.report.engine_check.q_b, check.q_b, rtol=1e-12)


def test_the_cross_check_says_where_its_runs_are():
    """The check has no bar of its own: at most every ``seconds`` one line with the evaluations and each run's
    phase."""
    lines = []
    progress = _every(0.0, lines.append, 1000)
    progress(0, 4000, 0.0, False, float("nan"))
    progress(1, 6500, 120.0, True, -3.2)
    assert lines == [
        "cross-check: 4,000 evaluations; run 0 exploring",
        "cross-check: 10,500 evaluations; run 0 exploring, run 1 n_eff 120/1000",
    ]
    quiet = []
    progress = _every(3600.0, quiet.append, 1000)
    progress(0, 4000, 0.0, False, float("nan"))
    assert quiet == []


def test_cross_check_is_validated():
    with pytest.raises(Exception, match="cross_check"):
        load_config(None, cross_check="dynesty")
