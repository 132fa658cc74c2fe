"""The full-model stage (studies/full_model.py, analyses.model_choice): its record, its code hash, how the default
study reads a committed record back, and its figure."""

import dataclasses
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from bayestissue.analyses import model_choice as MC
from bayestissue.analyses.records import FILES
from bayestissue.inference import NestedOptions
from bayestissue.inference.sampling.nested import nested_target
from bayestissue.inference.sampling.ultranest_run import slice_steps
from bayestissue.io.records import read_record, write_record
from bayestissue.plotting.evidence import plot_model_choice
from tests.study_module import load_study

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "tests" / "report" / "fixtures" / FILES[MC.ModelChoiceRecord]


@pytest.fixture(scope="module")
def record():
    return read_record(FIXTURE, MC.ModelChoiceRecord)


@pytest.fixture()
def stage():
    return load_study("full_model")


def test_the_hash_follows_the_data_and_the_settings(tmp_path):
    data = tmp_path / "T1.csv"
    data.write_text("t,u\n0,0\n")
    a = MC.numbers_hash([data], "settings")
    assert a == MC.numbers_hash([data], "settings") and len(a) == 16
    assert MC.numbers_hash([data], "other settings") != a
    data.write_text("t,u\n0,1\n")
    assert MC.numbers_hash([data], "settings") != a
    full = {m: MC.current_hash("full", ROOT / "data", "T1", m) for m in ("mirror", "full")}
    assert full["mirror"] != full["full"] != MC.current_hash("quick", ROOT / "data", "T1", "full")
    assert MC.current_hash("full", ROOT / "data", "T2", "full") != full["full"]
    # each model's hash follows its own settings only
    changed = {**MC.SETTINGS["full"], "mirror": {**MC.SETTINGS["full"]["mirror"], "n_live": 999}}
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(MC.SETTINGS, "full", changed)
        assert MC.current_hash("full", ROOT / "data", "T1", "mirror") != full["mirror"]
        assert MC.current_hash("full", ROOT / "data", "T1", "full") == full["full"]


def test_the_nested_runs_hash_leaves_out_the_modules_no_nested_run_imports(tmp_path):
    """NOT_NESTED (the importance sampler) is out of the runs' hash and in the evidence check's, and no module the
    runs' hash covers imports it (else a change of it could change their numbers unseen)."""
    import ast

    from bayestissue.io.results import source_files

    package = ROOT / "bayestissue"
    kept = [f.relative_to(package).as_posix() for f in source_files(MC.SOURCES, exclude=MC.NOT_NESTED)]
    every = [f.relative_to(package).as_posix() for f in source_files(MC.SOURCES)]
    assert set(every) - set(kept) == set(MC.NOT_NESTED)
    left_out = {m.removesuffix(".py").replace("/", ".") for m in MC.NOT_NESTED}
    for rel in kept:
        for node in ast.walk(ast.parse((package / rel).read_text())):
            if isinstance(node, ast.ImportFrom):
                base = "bayestissue." + "/".join(rel.split("/")[: -node.level]).replace("/", ".") if node.level else ""
                mod = (base + "." if base and node.module else base) + (node.module or "")
                names = {mod} | {f"{mod}.{a.name}" for a in node.names}
            elif isinstance(node, ast.Import):
                names = {a.name for a in node.names}
            else:
                continue
            assert not {n.removeprefix("bayestissue.") for n in names} & left_out, (rel, names)
    data = tmp_path / "T1.csv"
    data.write_text("t,u\n0,0\n")
    assert MC.numbers_hash([data], "s") != MC.numbers_hash([data], "s", exclude=())


def test_a_data_set_override_changes_that_data_set_only(stage):
    """OVERRIDES: the joint models take 4 slice steps per parameter (sds included) under --full, at least 4 per
    dimension the runs sample (twice UltraNest's default); T1 and T2 keep SETTINGS (their hashes are those of the
    settings without an override), and --quick has none."""
    for model, over in MC.OVERRIDES["full", "joint"].items():
        problem = MC.model_problem(ROOT / "data", "joint", model)
        opts = NestedOptions(**MC.model_settings("full", "joint", model))
        n_dim = nested_target(problem, opts)[0]
        assert over["slice_steps"] == 4 * problem.ndim and n_dim == problem.ndim - 2
        assert slice_steps(opts, n_dim) == over["slice_steps"] >= 2 * slice_steps(NestedOptions(), n_dim)
        assert MC.model_settings("full", "joint", model) == {**MC.SETTINGS["full"][model], **over}
        assert MC.model_settings("quick", "joint", model) == MC.SETTINGS["quick"][model]
    for data in ("T1", "T2"):
        assert MC.model_settings("full", data, "mirror") == MC.SETTINGS["full"]["mirror"]
    with pytest.MonkeyPatch.context() as mp:
        before = MC.current_hash("full", ROOT / "data", "joint", "mirror")
        mp.setattr(MC, "OVERRIDES", {})
        assert MC.current_hash("full", ROOT / "data", "joint", "mirror") != before


def test_the_record_keeps_each_run_and_the_quantiles_in_box_units():
    """model_evidence on a stand-in sample: runs in order, merged values, quantiles mapped by the prior's to_unit."""
    points = np.array([[0.5, 2.0], [500.0, 3.0]])  # the first inside the narrowed box [0.1, 100] of "a", the second not
    runs = [SimpleNamespace(log_z=z, log_z_err=0.1, n_like=100 + k, time_s=1.0, finished=True, points=points,
                            log_w=np.log([0.25, 0.75]), bootstrap_weights=None, n_like_resumed=0)
            for k, z in enumerate((10.0, 10.4))]  # fmt: skip
    specs = [SimpleNamespace(name="a", prior="loguniform", lower=0.01, upper=1000.0),
             SimpleNamespace(name="b", prior="uniform", lower=0.0, upper=10.0)]  # fmt: skip
    params = SimpleNamespace(to_unit=lambda x: np.asarray(x) / 10.0, sampled=specs)
    sample = SimpleNamespace(runs=runs, names=("a", "b"), log_z=10.2, log_z_err=0.2,
                             problem=SimpleNamespace(parameters=params))  # fmt: skip
    q = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    missed = "NOT CONVERGED: runs [1] never came within d/2 = 1 of the peak 19.5"
    report = SimpleNamespace(converged=False, verdict=lambda: missed, rhat=np.array([1.2, np.nan]),
                             quantiles=lambda: q, quantile_errors=lambda: q / 100, log_z_p=0.0047,
                             short_of_peak=np.array([False, True]), q_runs=np.stack([q, q + 1]),
                             max_log_l=np.array([20.0, 17.5]), reference_log_l=19.5)  # fmt: skip
    opts = SimpleNamespace(sampler="ultranest", n_live=50, slice_steps=None)
    e = MC.model_evidence("full", sample, report, opts, 3.0, "abc")
    assert e.max_log_l == [20.0, 17.5] and e.reference_log_l == 19.5
    assert e.verdict == missed  # the engine's line, as it is
    assert e.numbers_hash == "abc" and e.log_z == [10.0, 10.4] and e.calls == [100, 101] and e.merged == (10.2, 0.2)
    assert e.rhat_max == 1.2 and e.quantile("b") == [4.0, 5.0, 6.0]
    assert e.log_z_p == 0.0047 and e.peak_reached == [True, False] and not e.runs_agree
    assert e.box.names == ["a"] and e.box.narrowed[0] == pytest.approx(np.log(5 / 3) + np.log(0.25))
    four = dataclasses.replace(e, finished=[True] * 4, peak_reached=[True] * 4)
    assert four.runs_agree is False and dataclasses.replace(four, log_z_p=0.5).runs_agree
    assert e.unit_quantiles == (q / 10).tolist() and e.run_unit_quantiles[1] == ((q + 1) / 10).tolist()
    # the stage's wall time is this session's: NaN once a run was resumed from an earlier session's checkpoint
    assert e.wall_s == 3.0
    runs[1].n_like_resumed = 60
    assert np.isnan(MC.model_evidence("full", sample, report, opts, 3.0, "abc").wall_s)
    # without the least-squares reference the peak check has not run: refused rather than recorded as reached
    with pytest.raises(ValueError, match="no reference log-likelihood"):
        MC.model_evidence("full", sample, SimpleNamespace(**{**vars(report), "reference_log_l": None}), opts, 3.0, "a")


def test_the_default_study_reads_the_committed_record_and_says_whether_it_is_current(stage, record, tmp_path, capsys):
    out = tmp_path / "figures"
    out.mkdir()
    assert stage.main(["--out", str(out)]) == 0
    assert "not found: the default study reads the committed --full record" in capsys.readouterr().out
    now = {(d, m): MC.current_hash(record.mode, ROOT / "data", d, m) for d, c in record.cases.items() for m in c.models}
    cases = {
        d: dataclasses.replace(
            c, models={m: dataclasses.replace(e, numbers_hash=now[d, m]) for m, e in c.models.items()}
        )
        for d, c in record.cases.items()
    }
    t2 = cases["T2"]
    cases["T2"] = dataclasses.replace(
        t2, models={**t2.models, "full": dataclasses.replace(t2.models["full"], numbers_hash="0" * 16)}
    )
    write_record(out / FILES[MC.ModelChoiceRecord], dataclasses.replace(record, cases=cases))
    assert stage.main(["--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"T1, mirror model, code and data {now['T1', 'mirror']}): matches the current code" in printed
    assert f"T2, mirror model, code and data {now['T2', 'mirror']}): matches the current code" in printed
    assert f"T2, full model, code and data {'0' * 16}): STALE, the current code is {now['T2', 'full']}" in printed
    assert "(rerun: python studies/full_model.py --full --data T2 --models full)" in printed


def test_a_full_rerun_keeps_the_models_whose_runs_match_the_current_code(stage, record, monkeypatch, capsys):
    """Only a model whose hash changed is run again (here: none runs, the sampler is replaced by one that fails), and
    only among the models chosen to run: the others keep their runs, matching or not."""
    case = record.cases["T1"]
    now = {m: MC.current_hash("full", ROOT / "data", "T1", m) for m in case.models}
    current = dataclasses.replace(case, models={m: dataclasses.replace(e, numbers_hash=now[m])
                                                for m, e in case.models.items()})  # fmt: skip
    both, saved = {"mirror", "full"}, []

    def no_runs(*a, **k):
        raise AssertionError("a model whose runs match the current code was run again")

    monkeypatch.setattr(stage, "sample_nested", no_runs)
    kept = stage._case("full", "T1", 1, current, both, saved.append)
    assert kept.models == current.models and saved == []
    assert capsys.readouterr().out.count("matches the current code") == 2
    stale = dataclasses.replace(current, models={**current.models, "mirror": dataclasses.replace(
        current.models["mirror"], numbers_hash="0" * 16)})  # fmt: skip
    with pytest.raises(AssertionError, match="was run again"):
        stage._case("full", "T1", 1, stale, both, saved.append)
    assert stage._case("full", "T1", 1, stale, {"full"}, saved.append).models == stale.models  # mirror not chosen
    assert "0000000000000000, not chosen to run" in capsys.readouterr().out
    with pytest.raises(AssertionError, match="was run again"):  # --quick never keeps the runs it is asked for
        stage._case("quick", "T1", 1, current, {"full"}, saved.append)


def test_the_figure_shows_the_factor_and_every_parameter(record, tmp_path):
    case = record.cases["T1"]
    fig = plot_model_choice(case, record.mode, tmp_path / "m.png")
    assert (tmp_path / "m.png").stat().st_size > 10_000
    left, right = fig.axes
    m, f = case.models["mirror"], case.models["full"]
    assert f"ln B mirror over full = {m.merged[0] - f.merged[0]:.2f}" in left.get_title()
    assert case.log_bayes() == (m.merged[0] - f.merged[0], float(np.hypot(m.merged[1], f.merged[1])))
    assert [t.get_text() for t in right.get_yticklabels()] == f.names


@pytest.mark.slow
def test_the_quick_stage_runs_both_models_and_writes_its_record(tmp_path):
    """The stage's compute path end to end (capped runs: their numbers mean nothing): the record reads back with the
    current code's hash, both models' runs and the figure and summary beside it."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", MPLBACKEND="Agg")
    run = subprocess.run([sys.executable, str(ROOT / "studies" / "full_model.py"), "--quick", "--out", str(tmp_path)],
                         capture_output=True, text=True, cwd=ROOT, env=env, timeout=600)  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    rec = read_record(tmp_path / FILES[MC.ModelChoiceRecord], MC.ModelChoiceRecord)
    case = rec.cases["T1"]
    assert rec.mode == "quick" and list(rec.cases) == ["T1"]
    assert case.seed == MC.STAGE_SEED
    assert {m: e.numbers_hash for m, e in case.models.items()} == {
        m: MC.current_hash("quick", ROOT / "data", "T1", m) for m in ("mirror", "full")
    }
    assert [len(e.log_z) for e in case.models.values()] == [2, 2]
    for e in case.models.values():  # the peak check ran against the model's own least-squares optimum
        assert np.isfinite(e.reference_log_l) and len(e.max_log_l) == 2
        assert e.peak_reached == [v >= e.reference_log_l - len(e.names) / 2 for v in e.max_log_l]
    assert len(case.models["full"].names) == len(case.models["mirror"].names) + 3  # the three untied parameters
    assert "log Bayes factor mirror over full" in (tmp_path / "model_choice_T1.md").read_text()
    assert (tmp_path / "model_choice_T1.png").is_file()


def test_the_joint_data_set_fits_both_tests_and_adds_a_t2_stiffness_scale(stage, tmp_path):
    """The joint data set's hash follows both tests' files (the single tests' hashes are those of their own files),
    its models are the mirror and full models on T1 and T2 together plus the mirror model with one stiffness scale
    acting on T2 only, and each has its own seed."""
    data = tmp_path / "data"
    data.mkdir()
    for f in ("T1.toml", "T1.csv", "T2.toml", "T2.csv"):
        (data / f).write_bytes((ROOT / "data" / f).read_bytes())
    joint = MC.current_hash("full", data, "joint", "mirror")
    assert joint not in {MC.current_hash("full", data, t, "mirror") for t in ("T1", "T2")}
    assert MC.current_hash("full", data, "T1", "mirror") == MC.current_hash("full", ROOT / "data", "T1", "mirror")
    (data / "T2.csv").write_bytes((data / "T2.csv").read_bytes() + b"\n")
    assert MC.current_hash("full", data, "joint", "mirror") != joint
    assert MC.current_hash("full", data, "T1", "mirror") == MC.current_hash("full", ROOT / "data", "T1", "mirror")
    problems = {m: MC.model_problem(ROOT / "data", "joint", m) for m in MC.CANDIDATES["joint"]}
    assert list(problems) == ["mirror", "full", "scale"] and MC.FACTORS["joint"][1] == ("scale", "mirror")
    assert all(len(p.experiments) == 2 for p in problems.values())
    assert set(problems["scale"].names) - set(problems["mirror"].names) == {"scale"}
    assert (
        problems["full"].ndim == problems["mirror"].ndim + 3 and problems["scale"].ndim == problems["mirror"].ndim + 1
    )
    kinds = {t.name: getattr(t.forward, "kinds", None) for t in problems["scale"].experiments}
    assert kinds == {"T1": (), "T2": ("scale",)}  # the scale acts on T2's specimen only
    assert all(getattr(t.forward, "kinds", None) is None for t in problems["mirror"].experiments)


def test_the_figure_title_names_the_models_not_run_yet(record, tmp_path):
    case = record.cases["T1"]
    fig = plot_model_choice(case, record.mode, tmp_path / "t1.png")
    assert fig._suptitle.get_text() == "T1: the mirror model against the paper's 11 parameters (quick run)"
    joint = MC.DataChoice(data="joint", seed=MC.STAGE_SEED + 20, models={"mirror": case.models["mirror"]})
    fig = plot_model_choice(joint, record.mode, tmp_path / "joint.png")
    assert fig._suptitle.get_text() == "joint: mirror model runs; the full and scale models not run yet (quick run)"
    two = MC.DataChoice(data="joint", seed=MC.STAGE_SEED + 20, models=dict(case.models))
    title = plot_model_choice(two, record.mode, tmp_path / "two.png")._suptitle.get_text()
    assert title == (
        "joint: the mirror model against the paper's 11 parameters (the scale model not run yet) (quick run)"
    )


def test_the_summary_of_a_data_set_names_its_models_and_those_not_run_yet(stage, record):
    case = record.cases["T1"]
    assert stage._summary(case, "full").startswith("# The mirror and full models on T1 (full)\n")
    joint = MC.DataChoice(data="joint", seed=MC.STAGE_SEED + 20, models={"mirror": case.models["mirror"]})
    text = stage._summary(joint, "full")
    assert text.startswith("# The mirror model on joint (full; not run yet: full, scale)\n")
    assert "log Bayes factor" not in text


def test_a_factor_whose_runs_disagree_is_flagged_in_the_title_and_the_summary(stage, record, tmp_path):
    """The merged error of runs that disagree understates their scatter: the factor's title and summary line say it
    decides nothing, and say nothing where both models' runs agree."""
    case = record.cases["T1"]
    agree = {n: dataclasses.replace(e, finished=[True] * 4, peak_reached=[True] * 4, log_z_p=0.5)
             for n, e in case.models.items()}  # fmt: skip
    good = MC.DataChoice(data="T1", seed=case.seed, models=agree)
    assert good.factor_decides()
    bad = MC.DataChoice(
        data="T1", seed=case.seed, models={**agree, "full": dataclasses.replace(agree["full"], log_z_p=1e-5)}
    )
    assert not bad.factor_decides() and not bad.factor_decides("full", "mirror")
    for c, flagged in ((good, False), (bad, True)):
        title = plot_model_choice(c, "full", tmp_path / "f.png").axes[0].get_title()
        assert ("(runs disagree: no verdict)" in title) is flagged
        assert ("no verdict" in stage._summary(c, "full")) is flagged
