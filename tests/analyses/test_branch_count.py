"""The branch-count stage (studies/tendon_branches.py, analyses.branch_count): its code hash, the rule that picks a
count, how the default study reads a committed record back, and its figure."""

import dataclasses
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bayestissue.analyses import branch_count as BC
from bayestissue.analyses.records import FILES
from bayestissue.io.records import read_record, write_record
from bayestissue.plotting.branch_count import plot_branch_count
from tests.study_module import load_study

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "tests" / "report" / "fixtures" / FILES[BC.BranchCountRecord]


@pytest.fixture(scope="module")
def record():
    return read_record(FIXTURE, BC.BranchCountRecord)


@pytest.fixture()
def stage():
    return load_study("tendon_branches")


def _with(rec, n, **changes):
    """``rec`` with count ``n``'s evidence changed."""
    f = rec.fits[str(n)]
    return dataclasses.replace(rec, fits={**rec.fits, str(n): dataclasses.replace(
        f, evidence=dataclasses.replace(f.evidence, **changes))})  # fmt: skip


def _current(rec):
    return dataclasses.replace(rec, fits={k: dataclasses.replace(f, evidence=dataclasses.replace(
        f.evidence, numbers_hash=BC.count_hash(rec.mode, ROOT, int(k)))) for k, f in rec.fits.items()})  # fmt: skip


def test_the_hash_follows_the_configuration_the_data_and_the_mode(tmp_path):
    """Each count's hash covers its own experiment file and configuration, the shared CSV and the mode."""
    for sub in ("data/synthetic", "examples"):
        (tmp_path / sub).mkdir(parents=True)
    for n in BC.BRANCHES:
        shutil.copy(ROOT / "data" / "synthetic" / BC.DATA[n], tmp_path / "data" / "synthetic")
        shutil.copy(ROOT / "examples" / BC.CONFIGS[n], tmp_path / "examples")
    shutil.copy(ROOT / "data" / "synthetic" / BC.DATA_CSV, tmp_path / "data" / "synthetic")
    before = {n: BC.count_hash("full", tmp_path, n) for n in BC.BRANCHES}
    assert before == {n: BC.count_hash("full", ROOT, n) for n in BC.BRANCHES} and len(set(before.values())) == 3
    assert BC.count_hash("quick", tmp_path, 2) != before[2]
    config = tmp_path / "examples" / BC.CONFIGS[3]
    config.write_text(config.read_text() + "\n# a comment changes the bytes\n")
    assert BC.count_hash("full", tmp_path, 3) != before[3] and BC.count_hash("full", tmp_path, 2) == before[2]
    csv = tmp_path / "data" / "synthetic" / BC.DATA_CSV
    csv.write_text(csv.read_text() + "\n")
    assert all(BC.count_hash("full", tmp_path, n) != before[n] for n in (1, 2))


def test_the_evidence_picks_the_best_count_by_the_rule_its_runs_allow(record):
    """The committed runs: two branches, over one because both agree (195 nats), over three by the bound on the
    three-branch runs that disagree (highest -537.40 + 2 x 0.17, 1.43 nats below). The pick goes when the best
    count's own runs disagree, when the bound comes within 1 nat, or when a three-branch run missed the peak; with
    the three-branch runs agreeing the plain rule decides."""
    assert record.best == 2 and record.chosen == 2
    assert record.decides(1) == (True, "runs agree") and record.decides(3) == (True, "highest run + 2 sd")
    z3 = np.asarray(record.fits["3"].evidence.log_z)
    assert record.scatter_bound(3) == pytest.approx(record.log_z(2)[0] - z3.max() - 2 * np.std(z3, ddof=1))
    assert record.scatter_bound(3) == pytest.approx(1.4293, abs=1e-4)
    assert record.log_bayes(2, 3)[0] == pytest.approx(1.979, abs=1e-3)
    assert _with(record, 2, log_z_p=0.001).chosen is None  # the best count's runs disagree
    assert _with(record, 2, log_z_p=0.001).decides(3) == (False, "the 2-branch runs disagree")
    near = z3 + (record.scatter_bound(3) - 0.99)  # the bound 0.99 nats below the best
    assert _with(record, 3, log_z=near.tolist()).chosen is None
    assert _with(record, 3, peak_reached=[True, False, True, True]).chosen is None
    agree = _with(record, 3, log_z_p=0.5, merged=(record.log_z(2)[0] - 1.5, 0.05))
    assert agree.decides(3) == (True, "runs agree") and agree.chosen == 2
    # the generating count recovers every tissue term (the two relaxation times 1.86 and 29.8 s against 2 and 30);
    # one branch misses the relaxation at full hold (34.4 % against 44.9) and both its time and moduli
    assert record.recovered(2) == dict.fromkeys(record.truth_terms, True) and len(record.truth_terms) == 9
    assert not record.recovered(1)["relaxation at full hold"] and not record.recovered(1)["relaxation time t1"]
    one = dataclasses.replace(record, fits={"2": record.fits["2"]})
    assert one.chosen is None  # one count is no comparison


def test_the_default_study_reads_the_committed_record_and_says_whether_it_is_current(stage, record, tmp_path, capsys):
    out = tmp_path / "figures"
    out.mkdir()
    assert stage.main(["--out", str(out)]) == 0
    assert "not found: the default study reads the committed --full record" in capsys.readouterr().out
    current = _current(record)
    write_record(out / FILES[BC.BranchCountRecord], _with(current, 3, numbers_hash="0" * 16))
    assert stage.main(["--out", str(out)]) == 0
    printed = capsys.readouterr().out
    for n in (1, 2):
        assert f"{n} branch(es), code and data {current.fits[str(n)].evidence.numbers_hash}): matches" in printed
    assert f"3 branch(es), code and data {'0' * 16}): STALE" in printed
    assert "(rerun: python studies/tendon_branches.py --full --branches 3)" in printed
    summary = (out / "branch_count.md").read_text()
    assert "The evidence picks: 2" in summary and "decides (highest run + 2 sd)" in summary
    assert (out / "branch_count.png").stat().st_size > 20_000


def test_a_full_rerun_keeps_the_counts_whose_runs_match_the_current_code(stage, record, tmp_path, monkeypatch, capsys):
    """Only a stale count is fitted again (here the fit is replaced by one that records its calls)."""
    out = tmp_path / "figures"
    out.mkdir()
    current = _current(record)
    write_record(out / FILES[BC.BranchCountRecord], _with(current, 1, numbers_hash="0" * 16))
    fitted = []

    def fit(mode, n):
        fitted.append((mode, n))
        return current.fits[str(n)]

    monkeypatch.setattr(stage, "_fit", fit)
    assert stage.main(["--full", "--out", str(out)]) == 0
    assert fitted == [("full", 1)]
    assert capsys.readouterr().out.count("matches the current code") == 2
    assert read_record(out / FILES[BC.BranchCountRecord], BC.BranchCountRecord).fits == current.fits
    assert stage.main(["--full", "--branches", "2", "--out", str(out)]) == 0  # asked for, but current: kept
    assert fitted == [("full", 1)]


def test_the_figure_shows_the_counts_their_residuals_and_the_bound(record):
    fig = plot_branch_count(record)
    curves, residuals, evidence = fig.axes
    assert [t.get_text().split("\n")[0] for t in residuals.get_yticklabels()] == [
        "1 branch",
        "2 branches",
        "3 branches",
    ]
    assert "the evidence picks 2" in evidence.get_title() and "(bound 1.43)" in evidence.get_title()
    bound = [line for line in evidence.get_lines() if line.get_linestyle() == "--"]
    assert len(bound) == 1 and bound[0].get_ydata()[0] == pytest.approx(-record.scatter_bound(3))
    assert len(curves.get_lines()) == 4  # the data and one median per count


@pytest.mark.slow
def test_the_quick_stage_fits_one_and_two_branches_and_writes_its_record(tmp_path):
    """The stage's compute path end to end (capped runs: their numbers mean nothing): the record reads back with the
    current code's hash per count, the posterior predictive on the data's grid, figure and summary beside it."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", MPLBACKEND="Agg")
    run = subprocess.run([sys.executable, str(ROOT / "studies" / "tendon_branches.py"), "--quick", "--out",
                          str(tmp_path)], capture_output=True, text=True, cwd=ROOT, env=env, timeout=600)  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    rec = read_record(tmp_path / FILES[BC.BranchCountRecord], BC.BranchCountRecord)
    assert rec.mode == "quick" and rec.counts == [1, 2] and rec.true_branches == 2
    for n in rec.counts:
        f = rec.fits[str(n)]
        assert f.evidence.numbers_hash == BC.count_hash("quick", ROOT, n)
        assert len(f.evidence.log_z) == BC.QUICK["nested"]["n_runs"] and len(f.median) == len(rec.time_s) == 161
        assert np.all(np.asarray(f.lower) <= np.asarray(f.upper))
        times = [q for q in f.terms if q.startswith("relaxation time")]
        assert len(times) == n and all(f.units[q] == "s" for q in times)
    assert rec.truth_terms["relaxation time t1"] == pytest.approx(2.0)
    assert rec.truth_terms["relaxation time t1_2"] == pytest.approx(30.0, rel=1e-4)
    assert "| 1 | 6 |" in (tmp_path / "branch_count.md").read_text()
    assert (tmp_path / "branch_count.png").is_file()
