"""The evidence-check stage (analyses/evidence_check.py, studies/evidence_check.py): its factors and their rule, the
hash, the committed record read back, and the quick stage end to end."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from bayestissue.analyses.evidence_check import (
    CHECK_SEED,
    CHECK_SETTINGS,
    COLLAPSED_MODULE,
    PROPOSAL_ERROR,
    CheckCase,
    EvidenceCheckRecord,
    cached_check,
    check_hash,
    check_model,
    mirror_swap,
    proposal_run,
)
from bayestissue.analyses.model_choice import CANDIDATES, data_files, model_problem, numbers_hash
from bayestissue.analyses.records import FILES
from bayestissue.inference import NestedOptions, sample_nested
from bayestissue.io.records import read_record
from tests.study_module import load_study

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "tests" / "report" / "fixtures" / FILES[EvidenceCheckRecord]


@pytest.fixture(scope="module")
def record():
    return read_record(FIXTURE, EvidenceCheckRecord)


def _case(record, mirror, full, trusted=(True, True)):
    t1 = record.cases["T1"]
    checks = {m: dataclasses.replace(t1.checks[m], log_z=z, log_z_err=e, trusted=t)
              for m, (z, e), t in zip(("mirror", "full"), (mirror, full), trusted, strict=True)}  # fmt: skip
    return CheckCase(data="T1", checks=checks)


def test_the_factor_decides_only_between_trusted_estimates_of_a_positive_grade(record):
    case = _case(record, (10.0, 0.3), (7.0, 0.4))
    f = case.factor("mirror", "full")
    # the error: both delta-method errors and PROPOSAL_ERROR for each evidence, in quadrature
    assert (f["log_b"], f["err"]) == pytest.approx((3.0, np.sqrt(0.3**2 + 0.4**2 + 2 * PROPOSAL_ERROR**2)))
    assert f["favours"] == "mirror" and f["grade"] == "strong" and f["decides"] and f["trusted"]
    assert not _case(record, (10.0, 0.3), (7.0, 0.4), trusted=(True, False)).factor("mirror", "full")["decides"]
    within = _case(record, (10.0, 0.3), (8.7, 0.4)).factor("mirror", "full")  # 1.3 +- 0.70: within error
    assert within["grade"] == "within error" and not within["decides"]
    assert _case(record, (7.0, 0.3), (10.0, 0.4)).factor("mirror", "full")["favours"] == "full"
    assert case.factors_run == (("mirror", "full"),)
    assert CheckCase(data="T1", checks={"mirror": case.checks["mirror"]}).factors_run == ()


def test_the_hash_follows_the_data_the_model_and_the_mode(tmp_path):
    data = ROOT / "data"
    base = check_hash("full", data, "T1", "mirror")
    assert base == check_hash("full", data, "T1", "mirror")
    assert base != check_hash("full", data, "T1", "full")
    assert base != check_hash("quick", data, "T1", "mirror")
    for f in ("T1.toml", "T1.csv"):
        (tmp_path / f).write_bytes((data / f).read_bytes())
    assert check_hash("full", tmp_path, "T1", "mirror") == base
    (tmp_path / "T1.csv").write_bytes((data / "T1.csv").read_bytes() + b"\n")
    assert check_hash("full", tmp_path, "T1", "mirror") != base


def test_the_default_study_reads_the_committed_record_back_and_names_stale_checks(tmp_path, capsys):
    stage = load_study("evidence_check")
    rec = read_record(FIXTURE, EvidenceCheckRecord)
    path = tmp_path / FILES[EvidenceCheckRecord]
    path.write_bytes(FIXTURE.read_bytes())
    assert stage.main(["--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    n = sum(len(c.checks) for c in rec.cases.values())
    assert out.count("STALE") == n  # the fixture's hashes are no code's
    assert "rerun: python studies/evidence_check.py --full --data joint" in out
    assert (tmp_path / "evidence_check.md").is_file() and (tmp_path / "evidence_check.png").is_file()
    assert stage.main(["--out", str(tmp_path / "none")]) == 0
    assert "not found: the default study reads the committed --full record" in capsys.readouterr().out


def test_a_record_of_another_version_is_named_in_one_line_without_a_traceback(tmp_path, capsys):
    """The default study on a record an older stage wrote: exit 2 and one line naming the file, the version found
    and the one expected (the record's checks cannot be read, so nothing is redrawn)."""
    stage = load_study("evidence_check")
    text = FIXTURE.read_text().replace(f'"version": {EvidenceCheckRecord.VERSION}', '"version": 1', 1)
    (tmp_path / FILES[EvidenceCheckRecord]).write_text(text)
    assert stage.main(["--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "evidence_check_record.json version" in err
    assert f"expected version {EvidenceCheckRecord.VERSION}" in err and "got 1" in err
    assert not (tmp_path / "evidence_check.md").exists()


FULL = ["mu", "kappa", "ginf1", "gamma1", "beta1", "ginf2", "gamma2", "beta2", "ginf3", "gamma3", "beta3"]


def test_the_proposal_is_symmetrised_only_over_an_exchange_the_likelihood_keeps():
    """Families 2 and 3 both sampled and a likelihood symmetric in them: their index groups; a likelihood that
    changes by 1e-3 under the exchange, or a model that ties family 3 to family 2: none."""
    u = np.random.default_rng(0).random((40, 11))
    symmetric = lambda x: -np.sum((x[:, 5:8] - 0.3) ** 2 + (x[:, 8:11] - 0.3) ** 2, axis=1)  # noqa: E731
    assert mirror_swap(FULL, symmetric, u) == ((5, 6, 7), (8, 9, 10))
    assert mirror_swap(FULL, lambda x: symmetric(x) + 1e-3 * x[:, 5], u) is None
    assert mirror_swap(FULL[:8], lambda x: symmetric(np.hstack([x, x[:, 5:8]])), u[:, :8]) is None


@pytest.mark.slow
def test_the_quick_stage_checks_t1s_models_and_keeps_current_checks(tmp_path, capsys):
    """--quick (capped nautilus runs, 2 000 draws; its numbers mean nothing) writes a record whose checks carry the
    current hash; a second run keeps them instead of rerunning; with the record gone (a stage killed before it wrote
    it) the checks each model wrote to the cache when it finished are kept; a cached check of another hash is not."""
    stage = load_study("evidence_check")
    stage.CACHE = tmp_path / "cache"
    assert stage.main(["--quick", "--out", str(tmp_path)]) == 0
    rec = read_record(tmp_path / FILES[EvidenceCheckRecord], EvidenceCheckRecord)
    assert rec.mode == "quick" and list(rec.cases) == ["T1"] and list(rec.cases["T1"].checks) == ["mirror", "full"]
    for model, c in rec.cases["T1"].checks.items():
        assert c.numbers_hash == check_hash("quick", ROOT / "data", "T1", model)
        assert c.n_draws == (2000 if model == "mirror" else 500) and len(c.quantiles) == len(c.names)
        # how the evidence moves with the boxes: every log-uniform material parameter, from the one estimate's draws
        specs = model_problem(ROOT / "data", "T1", model).parameters.sampled[: len(c.names)]
        logs = [sp for sp in specs if sp.prior == "loguniform"]
        assert c.box.names == [sp.name for sp in logs] and len(c.box.narrowed_runs) == 1
        volume = -sum(math.log((math.log(sp.upper / sp.lower) + 2 * math.log(10)) / math.log(sp.upper / sp.lower))
                      for sp in logs)  # fmt: skip
        assert c.box.widened_volume == pytest.approx(volume, rel=1e-12) and c.box.widened_flat >= volume
    # the mirror model's plain estimate: 1 000 adaptation draws and 2 000 in the estimate; the full model's beta3
    # integrated out on one labelling of its mirror families (COLLAPSED: 250 and 500 draws), so no proposal
    # symmetrised over them
    mirror, full = rec.cases["T1"].checks["mirror"], rec.cases["T1"].checks["full"]
    assert mirror.calls == 3000 and mirror.swapped == [] and full.swapped == []
    assert "beta3 by quadrature: " in full.verdict and "2 finer grids" in full.verdict
    assert "draws off the labelling: no calls" in full.verdict
    assert full.quadrature.one_labelling and full.quadrature.outside > 0 and mirror.quadrature is None
    capsys.readouterr()
    assert stage.main(["--quick", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.count("matches the current code") == 2
    assert read_record(tmp_path / FILES[EvidenceCheckRecord], EvidenceCheckRecord) == rec
    (tmp_path / FILES[EvidenceCheckRecord]).unlink()
    assert stage.main(["--quick", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.count("kept") == 2
    assert read_record(tmp_path / FILES[EvidenceCheckRecord], EvidenceCheckRecord) == rec
    key = rec.cases["T1"].checks["full"].numbers_hash
    assert cached_check(stage.CACHE, "quick", "T1", "full", key) == rec.cases["T1"].checks["full"]
    assert cached_check(stage.CACHE, "quick", "T1", "full", "0" * 16) is None
    cached = stage.CACHE / f"quick_T1_full_{key}.json"  # a cached check of another record version is not taken
    text = cached.read_text()
    cached.write_text(text.replace(f'"version": {EvidenceCheckRecord.VERSION}', '"version": 2', 1))
    assert cached_check(stage.CACHE, "quick", "T1", "full", key) is None
    cached.write_text(text)
    # the importance sampler changed (the checks' hashes with it, not the nautilus runs'): the checks rerun from the
    # runs' cached draws, and give the same numbers
    for f in stage.CACHE.glob("quick_T1_*.json"):
        f.unlink()
    (tmp_path / FILES[EvidenceCheckRecord]).unlink()
    assert len(list(stage.CACHE.glob("proposal_quick_T1_*.npz"))) == 2
    assert stage.main(["--quick", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.count("(read from the cache)") == 2
    again = read_record(tmp_path / FILES[EvidenceCheckRecord], EvidenceCheckRecord).cases["T1"].checks
    for model, c in rec.cases["T1"].checks.items():  # the same numbers; only the importance sampling's seconds differ
        assert dataclasses.replace(again[model], time_s=c.time_s) == c
    # --models: the model not named keeps the record's check, even a stale one, and says so; the named one is checked
    path = tmp_path / FILES[EvidenceCheckRecord]
    path.write_text(path.read_text().replace(again["full"].numbers_hash, "0" * 16))
    capsys.readouterr()
    assert stage.main(["--quick", "--models", "mirror", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "T1, full model: kept (0000000000000000, STALE, not chosen to run)" in out
    assert "T1, mirror model: kept" in out and "matches the current code" in out
    assert read_record(path, EvidenceCheckRecord).cases["T1"].checks["full"].numbers_hash == "0" * 16


def test_a_killed_nautilus_run_resumes_from_its_checkpoint_and_gives_the_uninterrupted_runs_draws(tmp_path):
    """The proposal's nautilus run says how far it is while it runs and checkpoints beside its draws' file; a run
    killed half way (here: stopped at 1 500 of 3 000 calls, its checkpoint left) resumes from the checkpoint, says
    so, spends only the calls it had not, and gives the draws an uninterrupted run gives; the checkpoint is removed
    once the draws are written, and a second call reads them back."""
    problem = model_problem(ROOT / "data", "T1", "mirror")
    opts = dict(n_live=100, n_eff=200, n_runs=1, n_networks=1, n_processes=1, report_every=500)
    lines = []
    whole = proposal_run(problem, NestedOptions(**opts, max_evaluations=3000), 5, tmp_path / "a.npz", lines.append)
    assert lines[0].startswith("nautilus 500 calls, run 0 exploring, log Z ") and len(lines) == 6
    assert whole.calls == 3000 and not (tmp_path / "a.nautilus").exists() and (tmp_path / "a.npz").is_file()
    assert proposal_run(problem, NestedOptions(**opts, max_evaluations=3000), 5, tmp_path / "a.npz").cached
    killed = tmp_path / "b.nautilus"
    sample_nested(problem, options=NestedOptions(**opts, max_evaluations=1500), rng=5, checkpoint=killed)
    lines.clear()
    resumed = proposal_run(problem, NestedOptions(**opts, max_evaluations=3000), 5, tmp_path / "b.npz", lines.append)
    assert lines[0] == f"nautilus resumes from {killed}" and lines[1].startswith("nautilus 2000 calls, run 0 ")
    # the progress lines start past the kill (2 000 calls, not 500): only the calls not yet spent are run; the cost
    # counts both sessions'
    assert len(lines) == 4 and resumed.calls == 3000 and not killed.exists()
    assert np.array_equal(resumed.points, whole.points, equal_nan=True) and resumed.log_z == whole.log_z
    assert np.array_equal(resumed.weights, whole.weights)


@pytest.mark.slow
def test_a_collapsed_check_integrates_its_parameter_out_and_reports_the_quadrature(tmp_path):
    """The joint full model (COLLAPSED: kappa) under --quick settings (numbers mean nothing): the proposal is fitted
    over the other 10 parameters, symmetrised over families 2 and 3 at their shifted indices; the verdict names the
    quadrature and the share of weight on doubtful points; the quantiles cover all 11 parameters, kappa's drawn from
    its conditionals inside the box; the hash differs from the check's without the line quadrature."""
    problem = model_problem(ROOT / "data", "joint", "full")
    lines = []
    c = check_model(problem, ROOT / "data", "joint", "full", "quick", 7, lines.append, tmp_path)
    assert any("kappa integrated out by quadrature" in line for line in lines)
    # the likelihood calls: per point a 41-point bracket, 6 Newton steps of 3 and 12 nodes, and 41 more for each
    # re-bracket of a point whose peak lay beyond the last bracket's edge; kappa's draws for the quantiles reuse the
    # estimate's peaks (no calls)
    base = 750 * 71
    assert c.n_draws == 500 and c.calls >= base and (c.calls - base) % 41 == 0
    # the quadrature's counts as fields of the record, the verdict's words from the same counts
    k = c.quadrature
    assert (k.param, k.one_labelling, k.points, k.outside) == ("kappa", False, 750, 0) and 0 <= k.share <= 1
    assert f"kappa by quadrature: {k.text}, holding {k.share:.2g} of the weight" in c.verdict
    assert f"edge at {k.edge} of 750 points" in k.text and f"not concave at {k.flat}" in k.text
    # the estimate's weighted draws are kept beside the check, over the 10 parameters sampled
    with np.load(tmp_path / f"draws_quick_joint_full_{c.numbers_hash}.npz") as f:
        assert f["unit"].shape == (500, 10) and "kappa" not in f["names"] and np.isclose(np.exp(f["log_w"]).sum(), 1)
    assert len(c.quantiles) == len(c.names) == 11
    assert "kappa by quadrature: 41-point bracket" in c.verdict and "at most 4 re-brackets" in c.verdict
    assert "of the weight" in c.verdict
    assert c.swapped == [["ginf2", "gamma2", "beta2"], ["ginf3", "gamma3", "beta3"]]
    q = c.quantiles[c.names.index("kappa")]
    assert 0 < q[0] <= q[1] <= q[2] and np.all(np.isfinite(q))
    # the boxes' shift from the quantile draws, kappa among them
    assert c.box.names == ["mu", "kappa", "ginf1", "beta1", "ginf2", "beta2", "ginf3", "beta3"]
    # the line quadrature's module is in this check's hash, and in no other's
    files = data_files(ROOT / "data", "joint")
    assert c.numbers_hash == check_hash("quick", ROOT / "data", "joint", "full")
    for model in ("mirror", "scale"):
        settings = repr(("importance", CHECK_SEED, model, CANDIDATES["joint"][model], CHECK_SETTINGS["quick"]))
        assert check_hash("quick", ROOT / "data", "joint", model) == numbers_hash(files, settings, exclude=(
            COLLAPSED_MODULE,)) != numbers_hash(files, settings, exclude=())  # fmt: skip
