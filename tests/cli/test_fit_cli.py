"""`bayestissue fit`: a small end-to-end run, its outputs, and clear errors (exit 2) on bad input."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from bayestissue.cli import main
from bayestissue.io.results import read_inference_data
from bayestissue.io.tables import read_table

DATA = Path(__file__).resolve().parents[2] / "data"


def _config(tmp_path, text):
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(text)
    return str(cfg)


def test_fit_two_parameters_writes_results(tmp_path, capsys):
    cfg = _config(
        tmp_path,
        '[parameters]\nsampled = ["mu", "kappa"]\n[sampler]\nseed = 5\nn_ensembles = 2\n',
    )
    out = tmp_path / "out"
    code = main(
        ["fit", str(DATA / "T2.toml"), "--config", cfg, "--out", str(out), "--quick"]
        + ["--no-figures", "--no-progress"]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "paper's least squares" in text and "NOT CONVERGED" in text  # a 300-step smoke run
    import re

    # the verdict says how far each short ensemble is from the length criterion
    assert re.search(r"shorter than 50 tau .*\(0: 300 of 50 x [\d.]+ = \d+ steps", text), text
    cols, meta = read_table(out / "summary.csv", required=("parameter", "ls_estimate", "median"))
    assert list(cols["parameter"]) == ["mu", "kappa", "sigma_T2"]
    assert "ginf1=125" in meta["parameters_fixed"]
    # what to do about it: printed, and kept in the summary files beside the verdict
    (advice,) = [line for line in text.splitlines() if line.startswith("what to do: run longer")]
    assert meta["what_to_do"].startswith(advice.removeprefix("what to do: "))
    assert f"- what_to_do: {meta['what_to_do']}" in (out / "summary.md").read_text()
    idata = read_inference_data(out / "posterior.nc")
    assert idata.posterior.attrs["seed"] == 5
    assert "data_sha256:T2.csv" in idata.posterior.attrs
    assert (out / "checkpoints" / "ensemble_0.h5").is_file()
    assert np.all(np.isfinite(idata.posterior["mu"].values))


def test_fit_nested_engine_writes_evidence_weights_and_figures(tmp_path, capsys):
    """``engine = "nested"`` through the CLI on the T2 replica with mu and kappa sampled: the verdict and the
    evidence are printed, posterior.nc holds the equal-weight draws, the importance sample and the evidence, and
    the run figure replaces the traces."""
    cfg = _config(
        tmp_path,
        '[parameters]\nsampled = ["mu", "kappa"]\n[warmstart]\nn_starts = 1\n[sampler]\nseed = 5\n'
        "[nested]\nn_live = 200\nn_eff = 300\nn_runs = 2\nn_networks = 1\nreport_every = 1000\n",
    )
    out = tmp_path / "out"
    code = main(["fit", str(DATA / "T2.toml"), "--config", cfg, "--out", str(out), "--engine", "nested"])
    assert code == 0
    captured = capsys.readouterr()
    text = captured.out
    assert "nested sampling" in captured.err and "run 1 n_eff" in captured.err  # the progress bar
    assert "then 2 nested runs" in text
    assert "NOT CONVERGED: 2 run(s), at least 4 needed" in text
    idata = read_inference_data(out / "posterior.nc")
    attrs = idata.posterior.attrs
    assert attrs["engine"] == "nested (nautilus)"
    assert f"log evidence: {attrs['log_evidence']:.3f} +- {attrs['log_evidence_err']:.3f}" in text
    assert len(attrs["log_evidence_runs"]) == 2
    assert idata.posterior.sizes["chain"] == 2
    assert idata.importance_sample["weight"].sum() == pytest.approx(1.0)
    assert np.all(np.isfinite(idata.posterior["mu"].values))
    for k in range(2):
        assert (out / "checkpoints" / f"nested_{k}.h5").is_file()
    for name in ("corner", "nested_runs", "predictive_T2"):
        assert (out / f"{name}.png").stat().st_size > 10_000
    assert not (out / "traces.png").exists()
    cols, _ = read_table(out / "summary.csv", required=("parameter", "median", "rhat", "ess_bulk"))
    assert list(cols["parameter"]) == ["mu", "kappa", "sigma_T2"]


def test_fit_nested_on_the_folded_11_parameter_model_says_what_a_capped_run_missed(tmp_path, capsys):
    """The paper's 11 parameters with families 2/3 folded (exchangeable), two runs capped at 3000 evaluations: the
    pipeline runs end to end, the stored draws are folded (ginf2 >= ginf3), and the verdict names the cap and the
    missed peak (a capped run is nowhere near the likelihood's peak climbed from the least-squares optima)."""
    cfg = _config(
        tmp_path,
        '[parameters]\nexchangeable = [["ginf2", "gamma2", "beta2"], ["ginf3", "gamma3", "beta3"]]\n'
        '[warmstart]\nn_starts = 1\nmax_nfev = 50\n[sampler]\nengine = "nested"\n'
        "[nested]\nn_live = 100\nn_runs = 2\nn_networks = 1\nmax_evaluations = 3000\n",
    )
    out = tmp_path / "out"
    args = ["fit", str(DATA / "T1.toml"), "--config", cfg, "--out", str(out), "--no-progress", "--no-figures"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "runs [0, 1] stopped at the evaluation cap" in text
    assert "they missed the peak" in text
    assert "peak check: log-likelihood at the least-squares optima" in text  # the reference is climbed, and said
    post = read_inference_data(out / "posterior.nc").posterior
    assert np.all(post["ginf2"].values >= post["ginf3"].values)


@pytest.mark.slow
def test_fit_quick_all_parameters_with_figures_and_resume(tmp_path):
    out = tmp_path / "out"
    args = ["fit", str(DATA / "T2.toml"), "--out", str(out), "--quick", "--no-progress"]
    assert main(args) == 0
    for name in ("corner", "traces", "predictive_T2", "residuals_T2", "ls_history", "waterfall"):
        assert (out / f"{name}.png").stat().st_size > 10_000
    assert main(args + ["--resume", "--no-figures"]) == 0


@pytest.mark.parametrize(
    "config, match",
    [
        ('[parameters]\nfixed = ["mu"]\nsampled = ["mu"]\n', "either fixed or sampled"),
        ("[parameters]\nbounds = { mu = [10.0, 1.0] }\n", "mu bounds: expected lower < upper"),
        ("[parameters]\ninitial = { mu = 5000.0 }\n", "mu initial/fixed value: expected a value"),
        ('[parameters]\nsampled = ["nu"]\n', "sampled parameter names: expected names among"),
        ('[likelihood]\nnoise = "cauchy"\n', r"cfg.toml \[likelihood\] noise: expected one of"),
        (
            "[sampler]\nwalkers = 3\n",
            r"cfg.toml \[sampler\] key: expected one of .*got 'walkers' \(did you mean 'n_walkers'\?\)",
        ),
        # typed values (issue 19): strings for numbers, booleans for counts, fractions for seeds, ranges
        ('[sampler]\ntau_factor = "50"\n', r"\[sampler\] tau_factor: expected a number > 0, got '50'"),
        ('[sampler]\nsample = "false"\n', r"\[sampler\] sample: expected true or false, got 'false'"),
        ("[sampler]\nmax_steps = true\n", r"\[sampler\] max_steps: expected an integer >= 1, got True"),
        ("[sampler]\nseed = 1.5\n", r"\[sampler\] seed: expected an integer >= 0, got 1.5"),
        ("[sampler]\nn_ensembles = 1\n", r"\[sampler\] n_ensembles: expected an integer >= 2, got 1"),
        ('[output]\nn_predictive = "x"\n', r"\[output\] n_predictive: expected an integer >= 0, got 'x'"),
        ('[warmstart]\nmax_nfev = "x"\n', r"\[warmstart\] max_nfev: expected an integer >= 1, got 'x'"),
        ("[parameters]\nbounds = { mu = [1, 2, 3] }\n", r"\[parameters\] bounds: expected a table name = \[lower"),
        ('[likelihood]\nsd = "known"\n', r"\[likelihood\] sd: expected a number > 0 or \"data\""),
        # known only once the problem is built, still before any least squares or sampling
        ("[sampler]\nn_walkers = 4\n", r"\[sampler\] n_walkers: expected an integer >= 26 \(2 ndim \+ 2, ndim = 12\)"),
    ],
)
def test_fit_bad_config_exits_2(tmp_path, capsys, config, match):
    cfg = _config(tmp_path, config)
    code = main(["fit", str(DATA / "T2.toml"), "--config", cfg, "--out", str(tmp_path / "o")])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("bayestissue fit: error:")
    import re

    assert re.search(match, err), err
    assert not (tmp_path / "o").exists()  # refused input leaves no run directory behind


def test_fit_bad_experiment_files_exit_2(tmp_path, capsys):
    code = main(["fit", str(tmp_path / "missing.toml"), "--out", str(tmp_path / "o")])
    assert code == 2
    assert "missing.toml" in capsys.readouterr().err
    shutil.copy(DATA / "T2.toml", tmp_path / "T2.toml")
    lines = (DATA / "T2.csv").read_text().splitlines()
    header = [i for i, line in enumerate(lines) if line.startswith("time_s")][0]
    cells = lines[header + 5].split(",")
    cells[1] = "nan"
    lines[header + 5] = ",".join(cells)
    (tmp_path / "T2.csv").write_text("\n".join(lines) + "\n")
    code = main(["fit", str(tmp_path / "T2.toml"), "--out", str(tmp_path / "o")])
    assert code == 2
    assert "displacement_mm" in capsys.readouterr().err


def test_fit_nested_engine_with_ultranest_checkpoints_and_resumes(tmp_path, capsys):
    """``[nested] sampler = "ultranest"`` through the CLI (T2 replica, mu and kappa): the results file names the
    sampler and carries each run's insertion-order test, each run checkpoints to its UltraNest directory, and
    ``--resume`` of the finished run reads the stored evaluations back and gives the same evidence."""
    cfg = _config(
        tmp_path,
        '[parameters]\nsampled = ["mu", "kappa"]\n[warmstart]\nn_starts = 1\n[sampler]\nseed = 5\n'
        '[nested]\nsampler = "ultranest"\nn_live = 100\nn_eff = 200\nn_runs = 2\nn_processes = 1\n',
    )
    out = tmp_path / "out"
    argv = ["fit", str(DATA / "T2.toml"), "--config", cfg, "--out", str(out), "--engine", "nested", "--no-figures"]
    assert main([*argv, "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "NOT CONVERGED: 2 run(s), at least 4 needed" in text
    attrs = read_inference_data(out / "posterior.nc").posterior.attrs
    assert attrs["engine"] == "nested (ultranest)"
    assert len(attrs["insertion_test_passed_runs"]) == 2
    for k in range(2):
        assert (out / "checkpoints" / f"nested_{k}" / "results" / "points.hdf5").is_file()
    assert main([*argv, "--no-progress", "--resume"]) == 0
    again = capsys.readouterr().out
    assert "resuming" in again and "run 0 at " in again and "evaluations" in again
    back = read_inference_data(out / "posterior.nc").posterior.attrs
    assert abs(back["log_evidence"] - attrs["log_evidence"]) < 4 * attrs["log_evidence_err"]


def test_fit_reports_a_stalled_ultranest_run_in_one_line(tmp_path, capsys, monkeypatch):
    """A run whose step sampler stops producing points (UltraNest issues #166 / #177, stood in for by a sampler
    that evaluates one point over and over): ``fit`` ends with status 1 and one line naming the run, the calls and
    the way out, no traceback; the run's ledger is kept."""
    from ultranest import popstepsampler

    from tests.inference.inference_helpers import stuck_step_sampler

    stuck = stuck_step_sampler(popstepsampler.PopulationSliceSampler)
    monkeypatch.setattr(popstepsampler, "PopulationSliceSampler", stuck)
    cfg = _config(
        tmp_path,
        '[parameters]\nsampled = ["mu", "kappa"]\n[warmstart]\nn_starts = 0\n[sampler]\nseed = 5\n'
        '[nested]\nsampler = "ultranest"\nn_live = 50\nn_runs = 1\nn_processes = 1\npopulation = 2\nslice_steps = 2\n',
    )
    out = tmp_path / "out"
    argv = ["fit", str(DATA / "T2.toml"), "--config", cfg, "--out", str(out), "--engine", "nested"]
    code = main([*argv, "--no-figures", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 1
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "nested run 0 (UltraNest) stalled: no new point in 80" in err  # limit 200 x 2 x 2 = 800 calls
    assert 'sampler = "nautilus"' in err and str(out) in err
    assert (out / "checkpoints" / "nested_0.cost.json").is_file()


def test_fit_refuses_ultranest_on_a_likelihood_plateau_in_one_line(tmp_path, capsys):
    """The synthetic tendon preset (``data/synthetic/tendon_relaxation.toml``) has a plateau: where the recruitment
    stretch lies beyond the test's largest stretch 1.05 (75 % of its box [1, 1.2]) no fibre carries load and every
    point has log L = -1370.71. UltraNest stalled there (no new point after 60 iterations in 1.5 M calls); ``fit``
    now stops at the first step with status 1 and one line naming the plateau's value and the way out."""
    cfg = _config(
        tmp_path,
        "[parameters]\nfixed = { mu = 10.0, kappa = 10.0, disp1 = 0.02 }\n[warmstart]\nn_starts = 0\n"
        '[sampler]\nseed = 20261127\nengine = "nested"\n'
        '[nested]\nsampler = "ultranest"\nn_live = 100\nn_runs = 1\nn_processes = 1\npopulation = 10\n',
    )
    out = tmp_path / "out"
    argv = ["fit", str(DATA / "synthetic" / "tendon_relaxation.toml"), "--config", cfg, "--out", str(out)]
    code = main([*argv, "--no-figures", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 1
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "nested run 0 (UltraNest): " in err and "live points share log L = -1370.71 exactly" in err
    assert 'sampler = "nautilus"' in err and str(out) in err


@pytest.mark.parametrize("fixed", ["", ", gamma1_2 = 0.75"])
def test_fit_names_the_flat_direction_of_a_free_second_branch(tmp_path, capsys, fixed):
    """Two Prony branches with rel1_2 and gamma1_2 both sampled: ``fit`` says before any work that they make a flat
    direction and how to fix it (bayestissue.analyses.branch_ridges); with gamma1_2 fixed it says nothing."""
    cfg = _config(tmp_path, f"[parameters]\nfixed = {{ mu = 10.0, kappa = 10.0, disp1 = 0.02{fixed} }}\n"
                            "[warmstart]\nn_starts = 0\n")  # fmt: skip
    argv = ["fit", str(DATA / "synthetic" / "tendon_relaxation.toml"), "--config", cfg, "--out", str(tmp_path / "o")]
    assert main([*argv, "--no-sample", "--no-figures", "--no-progress"]) == 0
    out = capsys.readouterr().out.splitlines()
    notes = [s for s in out if s.startswith("note: rel1_2 and gamma1_2 are both sampled: 1 flat direction")]
    if fixed:
        assert notes == []
    else:
        assert len(notes) == 1 and "fixed = { gamma1_2 = 0.75 }" in notes[0] and out.index(notes[0]) < 2
