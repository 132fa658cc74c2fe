"""A population in a tissue's terms (workflows.population_terms), against closed forms the tissue terms must obey.

Stage-1 draws are synthetic (log-normal k1_1 and beta1 per specimen, gamma1 the same in every draw), so that on the
tendon tissue of data/synthetic/tendon_groups: a relaxation time is (1 - gamma1) / beta1 exactly, so its effect is
exp(-d_beta1) draw by draw and its typical median is (1 - gamma1) / exp(median of m + d); the stresses are increasing
in k1_1 and do not depend on beta1, so a quantile of the typical stress is the stress at that quantile of k1_1.
"""

from pathlib import Path

import numpy as np
import pytest

from bayestissue.inference.hierarchy import sample_population
from bayestissue.mechanics import load_experiment
from bayestissue.workflows import load_config
from bayestissue.workflows.population_terms import population_terms
from bayestissue.workflows.problem import build_problem
from bayestissue.workflows.tissue_terms import tissue_terms

DATA = Path(__file__).resolve().parents[2] / "data" / "synthetic" / "tendon_groups"
GAMMA = 0.5


@pytest.fixture(scope="module")
def population():
    config = load_config(DATA / "fit.toml")
    exps = [load_experiment(DATA / f"{n}.toml") for n in ("fresh_1", "fresh_2", "incubated_1", "incubated_2")]
    material = build_problem(exps[:1], config).material
    names = list(material.sampled_names)
    assert names == ["k1_1", "gamma1", "beta1"]
    rng = np.random.default_rng(4)
    centres = [(5.0e4, 0.10), (5.6e4, 0.09), (3.0e4, 0.13), (2.7e4, 0.12)]
    full = []
    for k1, beta in centres:
        n = 3000
        full.append(np.column_stack([k1 * np.exp(0.01 * rng.standard_normal(n)), np.full(n, GAMMA),
                                     beta * np.exp(0.02 * rng.standard_normal(n))]))  # fmt: skip
    cols = [0, 2]
    specs = [material.sampled[names.index(n)] for n in ("k1_1", "beta1")]
    post = sample_population([f[:, cols] for f in full], specs, ["fresh", "fresh", "incubated", "incubated"],
                             n_chains=2, n_warmup=200, n_draws=301, seed=2)  # fmt: skip
    virtual = [(e, material.expand) for e in exps]
    terms = population_terms(post, full, cols, virtual, n_draws=10_000, seed=3)
    return post, terms, exps, material, full


def test_relaxation_time_follows_the_population_exactly(population):
    post, terms, *_ = population
    for g, group in enumerate(post.groups):
        beta = np.exp(post.group_mean(g)[:, 1])
        t = terms.typical[group]["relaxation time t1"]
        np.testing.assert_allclose(t, (1.0 - GAMMA) / beta, rtol=1e-12)
    row = next(r for r in terms.effect_rows() if r["quantity"] == "relaxation time t1")
    expect = np.quantile(np.exp(-post.flat("d")[:, 0, 1]), [0.5, 0.05, 0.95])
    np.testing.assert_allclose([row["median"], row["lower"], row["upper"]], expect, rtol=1e-10)
    assert row["kind"] == "ratio" and row["group"] == "incubated" and row["reference"] == "fresh"


def test_stress_quantiles_are_the_stress_at_the_modulus_quantiles(population):
    post, terms, exps, material, full = population
    rows = {(r["group"], r["quantity"]): r for r in terms.group_rows()}
    for g, group in enumerate(post.groups):
        k1 = np.quantile(np.exp(post.group_mean(g)[:, 0]), [0.5, 0.05, 0.95])
        theta = np.column_stack([k1, np.full(3, GAMMA), np.full(3, 0.1)])  # beta does not enter a stress
        # the specimens share dimensions and tissue: any one is the virtual test
        direct = tissue_terms(exps[0], material.expand(theta), strain=terms.strain)
        for label in ("instantaneous", "equilibrium"):
            r = rows[(group, f"secant modulus ({label})")]
            np.testing.assert_allclose([r["typical"], r["typical_lower"], r["typical_upper"]],
                                       direct.values[f"secant modulus ({label})"][1], rtol=2e-3)  # fmt: skip
        # a new specimen's range is wider than the typical specimen's interval
        r = rows[(group, "secant modulus (instantaneous)")]
        assert r["new_lower"] < r["typical_lower"] and r["new_upper"] > r["typical_upper"]


def test_effects_in_a_tissue_terms(population):
    post, terms, *_ = population
    eff = {r["quantity"]: r for r in terms.effect_rows()}
    ratio_k1 = np.median(np.exp(post.flat("d")[:, 0, 0]))
    # fibre-dominated at 5 % strain: the modulus ratio is the fibre modulus ratio within the matrix's share
    assert eff["secant modulus (instantaneous)"]["median"] == pytest.approx(ratio_k1, rel=0.02)
    p_d = np.mean(post.flat("d")[:, 0, 0] > 0)  # the stress increases with k1_1: the same event
    assert eff["secant modulus (instantaneous)"]["p_positive"] == pytest.approx(p_d, abs=0.01)
    # every draw relaxes by gamma's share in both groups: no difference
    relax = eff["relaxation at full hold"]
    assert relax["kind"] == "difference" and abs(relax["median"]) < 0.5
    assert terms.strain == pytest.approx(0.05)
    assert "| incubated vs fresh | relaxation time t1 | ratio" in terms.markdown()


def test_same_seed_same_terms(population):
    post, terms, exps, material, full = population
    again = population_terms(post, full, [0, 2], [(e, material.expand) for e in exps], n_draws=10_000, seed=3)
    for g in post.groups:
        for name, v in terms.new[g].items():
            np.testing.assert_array_equal(v, again.new[g][name])
