"""The cut posterior over stereology replicates for any tissue (bayestissue.workflows.cut): each replicate's
directions, fractions and fibre dispersions reach its calibration; the draws pool in equal shares; bad tables are
refused before any work."""

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.io.stereology_files import read_replicates, write_replicates
from bayestissue.mechanics import load_experiment
from bayestissue.stereology import stereology_replicates
from bayestissue.stereology.axial import watson_goh_dispersion
from bayestissue.stereology.lines import LineSystem
from bayestissue.stereology.point_counts import PointCounts
from bayestissue.workflows import load_config
from bayestissue.workflows.cut import (
    choose_replicates,
    replicate_experiments,
    replicate_fixed,
    run_cut_calibration,
    write_cut_summary,
)

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    """Six replicates of the bundled (synthetic) stereology with the Watson directions: dispersion columns."""
    cols, info = stereology_replicates(
        PointCounts.from_file(DATA / "stereology_counts.csv"),
        LineSystem.from_file(DATA / "stereology_lines.csv"),
        n_boot=6,
        rng=3,
    )
    path = tmp_path_factory.mktemp("rep") / "R.csv"
    write_replicates(path, cols)
    return path, cols, info


@pytest.fixture
def hgo_t1(tmp_path):
    shutil.copy(DATA / "T1.csv", tmp_path / "T1.csv")
    (tmp_path / "T1.toml").write_text((DATA / "T1.toml").read_text() + '\n[tissue]\nfibre = "hgo"\n')
    return tmp_path / "T1.toml"


def test_table_carries_the_watson_dispersion(table):
    path, cols, info = table
    reps = read_replicates(path)
    assert reps["dispersion"].shape == (6, 3)
    # the point estimate's dispersion is the GOH map of its concentrations (mapping checked by quadrature in
    # tests/stereology/test_dispersion.py); concentrated families: kappa well below the isotropic 1/3
    assert np.allclose(info["dispersion"], watson_goh_dispersion(info["concentrations"]))
    assert np.all((reps["dispersion"] > 0.0) & (reps["dispersion"] < 0.1))
    # the replicates scatter: a spread to carry
    assert np.all(np.std(reps["dispersion"], axis=0) > 0.0)


def test_bad_dispersion_columns_refused(table, tmp_path):
    path, cols, _ = table
    bad = dict(cols)
    bad["disp_fibre2"] = np.where(np.arange(6) == 4, 0.4, cols["disp_fibre2"])
    write_replicates(tmp_path / "bad.csv", bad)
    with pytest.raises(
        ValidationError,
        match=r"bad.csv: disp_fibre2 of replicate row 5: expected a GOH dispersion in \[0, 1/3\], got 0.4",
    ):
        read_replicates(tmp_path / "bad.csv")
    text = (tmp_path / "bad.csv").read_text().replace(",disp_fibre3", ",other")
    (tmp_path / "partial.csv").write_text(text)
    with pytest.raises(ValidationError, match="all of .*disp_fibre3.* or none"):
        read_replicates(tmp_path / "partial.csv")


def test_replicate_inputs_reach_the_tissue(table, hgo_t1):
    path, _, _ = table
    reps = read_replicates(path)
    e = load_experiment(hgo_t1)
    (r,) = replicate_experiments([e], reps, 4)
    assert np.allclose(r.tissue.directions, reps["directions"][4], atol=1e-9)
    assert r.tissue.fibre == e.tissue.fibre and r.tissue.bulk_kpa == e.tissue.bulk_kpa
    held = replicate_fixed(e.tissue, reps, 4)
    assert held == {f"disp{k}": pytest.approx(reps["dispersion"][4, k - 1]) for k in (1, 2, 3)}
    # the paper's linear fibre has no dispersion: nothing held
    assert replicate_fixed(load_experiment(DATA / "T1.toml").tissue, reps, 4) == {}
    # a dispersed fibre law and a table without dispersion: refused (the cut would sample what was measured)
    with pytest.raises(ValidationError, match="no disp_fibre1..3 columns"):
        replicate_fixed(e.tissue, {**reps, "dispersion": None}, 0)
    # a tissue of another family count does not fit the table
    one = replace(e.tissue, directions=[[1.0, 0, 0]], phi_fibres=[0.6], phi_matrix=0.4, eps0=None)
    with pytest.raises(ValidationError, match="fibre families"):
        replicate_experiments([replace(e, tissue=one)], reps, 0)


def test_rows_are_seeded():
    assert choose_replicates(300, 4, 7) == choose_replicates(300, 4, 7)
    assert choose_replicates(3, 4, 7) == [0, 1, 2]
    with pytest.raises(ValidationError, match="n-replicates"):
        choose_replicates(300, 1, 7)


@pytest.fixture(scope="module")
def short_cut(table, tmp_path_factory):
    """A short cut run (not converged, 2 ensembles x 60 steps) of T1 under exponential fibres over 2 replicates."""
    path, _, _ = table
    d = tmp_path_factory.mktemp("hgo")
    shutil.copy(DATA / "T1.csv", d / "T1.csv")
    (d / "T1.toml").write_text((DATA / "T1.toml").read_text() + '\n[tissue]\nfibre = "hgo"\n')
    reps = read_replicates(path)
    cfg = load_config(None, n_starts=0, ls_max_nfev=60, seed=5, n_predictive=20,
                      sampler={"n_ensembles": 2, "max_steps": 60, "check_every": 60, "prune_rounds": 0,
                               "adapt_steps": 30, "adapt_rounds": 1})  # fmt: skip
    cut = run_cut_calibration([load_experiment(d / "T1.toml")], cfg, reps, n_replicates=2, out_dir=d / "cut")
    return reps, cut, d / "cut"


def test_cut_calibration_holds_each_replicates_dispersion(short_cut):
    """Each replicate's problem holds its own dispersions and samples the rest; the pooled draws are equal shares
    of the replicates'."""
    reps, cut, _ = short_cut
    assert len(cut.outcomes) == 2 and cut.rows == choose_replicates(6, 2, 5)
    for r, held, o in zip(cut.rows, cut.fixed, cut.outcomes, strict=True):
        assert sorted(held) == ["disp1", "disp2", "disp3"]
        assert not set(held) & set(o.sample.names)
        specs = {s.name: s for s in o.problem.parameters.specs}
        for name in held:
            assert specs[name].fixed
            assert specs[name].value == pytest.approx(reps["dispersion"][r, int(name[-1]) - 1])
    n = cut.within.shape[1]
    assert cut.pooled.shape == (2 * n, len(cut.names))
    rows = cut.table()
    assert [row["parameter"] for row in rows] == list(cut.names)
    assert all(row["lower"] <= row["median"] <= row["upper"] for row in rows)


def test_cut_summary_files(short_cut, tmp_path):
    _, cut, out = short_cut
    text = write_cut_summary(cut, tmp_path)
    assert (tmp_path / "cut_marginals.png").stat().st_size > 10_000
    table = (tmp_path / "cut_summary.csv").read_text()
    assert all(name in table for name in cut.names)
    for r, held in zip(cut.rows, cut.fixed, strict=True):
        assert f"| {r + 1} | disp1 = {held['disp1']:.4f}" in text
    # each replicate's own run directory, as a single fit writes it
    assert sorted(p.parent.name for p in out.glob("replicate_*/posterior.nc")) == sorted(
        f"replicate_{r + 1}" for r in cut.rows
    )
    # and its tissue terms over the posterior draws (bayestissue.workflows.tissue_terms)
    for r, o in zip(cut.rows, cut.outcomes, strict=True):
        assert len(o.tissue_terms.values["secant modulus (equilibrium)"][1]) > 100
        assert "90 % interval over" in (out / f"replicate_{r + 1}" / "tissue_terms.md").read_text()
