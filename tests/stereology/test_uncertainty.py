"""Bootstraps for systematic samples, axis alignment, confidence cones and the replicate table."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology.axial import (
    axial_angle,
    fit_watson,
    orientation_tensor,
    principal_axes,
    sample_watson,
)
from bayestissue.stereology.lines import LineSystem
from bayestissue.stereology.point_counts import PointCounts
from bayestissue.stereology.replicates import (
    DISPERSION_COLUMNS,
    REPLICATE_COLUMNS,
    direction_bootstrap,
    fibre_fraction_split,
    fit_fibre_directions,
    fraction_replicates,
    replicate_table,
    stereology_replicates,
)
from bayestissue.stereology.sections import fraction_covariance
from bayestissue.stereology.uncertainty import (
    align_axes,
    bootstrap_cells,
    cluster_fraction_bootstrap,
    confidence_cones,
    logistic_normal_draws,
    naive_section_bootstrap,
    parametric_fraction_bootstrap,
)


def _rotation(deg_z):
    a = np.radians(deg_z)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def test_align_axes_permutation_and_sign():
    est = np.array([-PAPER_DIRECTIONS[2], PAPER_DIRECTIONS[0], -PAPER_DIRECTIONS[1]]) @ _rotation(2).T
    aligned, order = align_axes(est, PAPER_DIRECTIONS)
    assert order.tolist() == [1, 2, 0]
    assert np.all(np.sum(aligned * PAPER_DIRECTIONS, axis=1) > 0.99)
    batch, orders = align_axes(np.stack([est, est[[2, 0, 1]]]), PAPER_DIRECTIONS)
    np.testing.assert_allclose(batch[0], batch[1])
    with pytest.raises(ValidationError, match="axes"):
        align_axes(np.eye(2), PAPER_DIRECTIONS)


def test_logistic_normal_draws_on_simplex_with_target_moments():
    mean = np.array([0.589, 0.411])
    sd = 0.02
    cov = np.array([[sd**2, -(sd**2)], [-(sd**2), sd**2]])
    x = logistic_normal_draws(mean, cov, 40000, rng=0)
    assert np.all((x > 0) & (x < 1)) and np.allclose(x.sum(axis=1), 1)
    assert x.mean(axis=0) == pytest.approx(mean, abs=1e-3)
    assert x[:, 0].std() == pytest.approx(sd, rel=0.03)
    three = logistic_normal_draws([0.5, 0.3, 0.2], np.diag([1e-4, 1e-4, 2e-4]), 1000, rng=1)
    assert np.allclose(three.sum(axis=1), 1)
    with pytest.raises(ValidationError, match="summing to 1"):
        logistic_normal_draws([0.5, 0.6], cov, 10)


def _counts(n=12, seed=0):
    rng = np.random.default_rng(seed)
    P = rng.integers(250, 320, n)
    Q = np.round(P * (0.589 + 0.03 * np.sin(np.arange(n) / 2)))
    return np.stack([Q, P - Q], axis=1)


def test_parametric_bootstrap_matches_predicted_covariance():
    Q = _counts()
    draws = parametric_fraction_bootstrap(Q, n_boot=20000, rng=1)
    cov = fraction_covariance(Q)
    assert draws[:, 0].std() == pytest.approx(np.sqrt(cov[0, 0]), rel=0.05)
    assert draws.mean(axis=0) == pytest.approx(Q.sum(axis=0) / Q.sum(), abs=1e-3)
    assert np.allclose(draws.sum(axis=1), 1)


def test_naive_and_cluster_bootstraps():
    Q = _counts()
    naive = naive_section_bootstrap(Q, n_boot=4000, rng=2)
    para = parametric_fraction_bootstrap(Q, n_boot=4000, rng=2)
    assert naive[:, 0].std() > para[:, 0].std()
    # cluster bootstrap: 4 blocks with different fractions; spread = between-block spread / sqrt(4)
    blocks = np.repeat([0, 1, 2, 3], 3)
    Qb = Q.astype(float).copy()
    Qb[:, 0] = np.round(Q.sum(axis=1) * np.repeat([0.5, 0.55, 0.6, 0.65], 3))
    Qb[:, 1] = Q.sum(axis=1) - Qb[:, 0]
    cl = cluster_fraction_bootstrap(Qb, blocks, n_boot=20000, rng=3)
    per_block = np.array([Qb[blocks == b, 0].sum() / Qb[blocks == b].sum() for b in range(4)])
    assert cl[:, 0].std() == pytest.approx(per_block.std() / 2, rel=0.1)
    with pytest.raises(ValidationError, match=">= 2 independent units"):
        cluster_fraction_bootstrap(Q, np.zeros(12), n_boot=10)
    with pytest.raises(ValidationError, match="n_boot"):
        naive_section_bootstrap(Q, n_boot=0)


def _watson_cells(n, kappa, rng, mu=(0.0, 1.0, 0.0)):
    d = sample_watson(n, mu, kappa, rng=rng)
    return LineSystem(np.zeros((n, 3)), 10 * d, np.arange(n))


def _cone_coverage(n_trials, n_boot, seed):
    rng = np.random.default_rng(seed)
    mu = np.array([0.0, 1.0, 0.0])
    hits = 0
    for _ in range(n_trials):
        ls = _watson_cells(50, 10.0, rng)
        d = ls.directions
        est = fit_watson(d)[0]

        def estimator(idx, d=d):  # the Watson MLE axis = principal axis of the orientation tensor
            return principal_axes(orientation_tensor(d[idx]))[1][:, :1].T, np.ones(1)

        reps, _ = bootstrap_cells(ls.cell, estimator, n_boot=n_boot, rng=rng)
        cone = confidence_cones(reps, est[None])[0]
        hits += axial_angle(est, mu) <= cone
    return hits / n_trials


def test_cone_coverage_quick():
    # Watson kappa = 10, n = 50 cells: coverage of the 95 % cone (docs/stereology.md: about 95 %)
    cov = _cone_coverage(60, 150, seed=4)
    assert 0.85 <= cov <= 1.0


@pytest.mark.slow
def test_cone_coverage_slow():
    cov = _cone_coverage(400, 200, seed=5)
    assert 0.92 <= cov <= 0.98


def test_bootstrap_cells_resamples_whole_cells():
    seen = []

    def estimator(idx):
        seen.append(idx)
        return np.eye(3), np.ones(3) / 3

    cells = np.array([1, 1, 1, 2, 2, 3])
    bootstrap_cells(cells, estimator, n_boot=20, rng=0)
    for idx in seen:
        # whole cells: segments of cell 1 (0, 1, 2) always come together
        c = np.bincount(idx, minlength=6)
        assert c[0] == c[1] == c[2] and c[3] == c[4]
    with pytest.raises(ValidationError, match=">= 2 traced cells"):
        bootstrap_cells([1, 1], estimator, n_boot=2)


def test_fibre_fraction_split():
    np.testing.assert_allclose(fibre_fraction_split(0.6), [[0.2, 0.2, 0.2]])
    np.testing.assert_allclose(
        fibre_fraction_split([0.6], method="length", shares=[0.5, 0.25, 0.25]), [[0.3, 0.15, 0.15]]
    )
    with pytest.raises(ValidationError, match="'paper' or 'length'"):
        fibre_fraction_split(0.6, method="volume")
    with pytest.raises(ValidationError, match="length shares"):
        fibre_fraction_split(0.6, method="length")


def test_replicate_table_aligns_to_paper_and_splits():
    B = 4
    rng = np.random.default_rng(0)
    perm = [rng.permutation(3) for _ in range(B)]
    D = np.stack([(PAPER_DIRECTIONS * np.array([[1], [-1], [1]]))[p] for p in perm])
    shares = np.stack([np.array([0.5, 0.3, 0.2])[p] for p in perm])
    fr = {"smc": np.full(B, 0.589), "ecm": np.full(B, 0.411)}
    cols = replicate_table(fr, D, split="length", shares=shares)
    assert tuple(cols) == REPLICATE_COLUMNS
    for k in range(3):
        v = np.stack([cols[f"v{k + 1}_{c}"] for c in "xyz"], axis=1)
        np.testing.assert_allclose(v, np.broadcast_to(PAPER_DIRECTIONS[k], v.shape), atol=1e-12)
    np.testing.assert_allclose(cols["phi_fibre1"], 0.589 * 0.5)
    np.testing.assert_allclose(cols["phi_matrix"], 0.411)
    paper = replicate_table(fr, D, split="paper")
    np.testing.assert_allclose(paper["phi_fibre2"], 0.589 / 3)
    with pytest.raises(ValidationError, match="a 'ecm' component"):
        replicate_table({"smc": fr["smc"]}, D)
    with pytest.raises(ValidationError, match="\\(4, 3, 3\\)"):
        replicate_table(fr, D[:2])


def _small_data(seed=0):
    rng = np.random.default_rng(seed)
    from bayestissue.stereology.axial import WatsonMixture

    mix = WatsonMixture(PAPER_DIRECTIONS, [30.0, 30.0, 30.0], [0.45, 0.3, 0.25])
    d, _ = mix.sample(240, rng=rng)
    cell = np.repeat(np.arange(80), 3)
    d = np.repeat(d[::3], 3, axis=0) + rng.normal(0, 0.03, (240, 3))
    start = rng.random((240, 3)) * 50
    lines = LineSystem(start, start + 8 * d, cell, volume_um3=1e5)
    Q = _counts()
    counts = PointCounts(np.arange(0, 72, 6), np.c_[Q, 400 - Q.sum(axis=1)], ("smc", "ecm", "other"), ("other",))
    return counts, lines


def test_stereology_replicates_pipeline():
    counts, lines = _small_data()
    for method in ("watson", "rose"):
        cols, info = stereology_replicates(counts, lines, n_boot=25, method=method, split="length", rng=1)
        # the Watson mixture also gives each family's dispersion; the rose fits no concentration
        extra = DISPERSION_COLUMNS if method == "watson" else ()
        assert tuple(cols) == REPLICATE_COLUMNS + extra and cols["replicate"].size == 25
        if method == "watson":
            d = np.stack([cols[c] for c in DISPERSION_COLUMNS], axis=1)
            assert np.all((d > 0) & (d < 1 / 3)) and np.all(np.isfinite(info["dispersion"]))
        else:
            assert np.all(np.isnan(info["dispersion"]))
        assert np.all(info["angle_to_paper_deg"] < 8)
        phi_f = np.stack([cols[f"phi_fibre{k}"] for k in (1, 2, 3)], axis=1)
        np.testing.assert_allclose(phi_f.sum(axis=1), cols["phi_smc"])
        np.testing.assert_allclose(cols["phi_smc"] + cols["phi_ecm"], 1.0)
        for k in (1, 2, 3):
            v = np.stack([cols[f"v{k}_{c}"] for c in "xyz"], axis=1)
            np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0)
            assert np.all(v @ PAPER_DIRECTIONS[k - 1] >= 0)
    b = direction_bootstrap(lines, method="watson", n_boot=30, rng=2)
    assert np.all(b["length_ci_um"][0] <= b["lengths_um"]) and np.all(b["lengths_um"] <= b["length_ci_um"][1])
    assert b["lengths_um"].sum() == pytest.approx(lines.total_length_um)
    assert np.all(b["cone_deg"] < 15)
    axes, shares = fit_fibre_directions(lines)
    assert shares.sum() == pytest.approx(1.0)
    with pytest.raises(ValidationError, match="method"):
        fit_fibre_directions(lines, method="hough")
    with pytest.raises(ValidationError, match="kind"):
        fraction_replicates(counts, kind="jackknife")
    with pytest.raises(ValidationError, match="'block' column"):
        fraction_replicates(counts, kind="cluster")
    bad = PointCounts(counts.section, counts.counts, ("smc", "collagen", "other"), ("other",))
    with pytest.raises(ValidationError, match="component: expected one of the reference"):
        stereology_replicates(bad, lines, n_boot=2)
