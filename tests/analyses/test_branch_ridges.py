"""Flat directions of a Prony series (bayestissue.analyses.branch_ridges): the count, and that the likelihood is
flat along the direction the module's docstring names."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bayestissue.analyses.branch_ridges import branch_ridges
from bayestissue.mechanics import TissueConfig, load_experiment, simulate
from bayestissue.mechanics.branches import with_second_branch
from bayestissue.mechanics.laws import fibre_law
from bayestissue.paper import PAPER_PARAMETERS

ROOT = Path(__file__).resolve().parents[2]
TENDON = ROOT / "data" / "synthetic" / "tendon_relaxation.toml"
#: the generating values of data/synthetic/tendon_relaxation.csv (studies/make_tendon_example.py)
TRUTH = {"mu": 10.0, "kappa": 10.0, "k1_1": 5.0e4, "k2_1": 2.0, "disp1": 0.02, "lamr1": 1.01, "gamma1": 0.4,
         "beta1": 0.3, "rel1_2": 0.8, "gamma1_2": 0.5, "beta1_2": 0.5 / 30.0}  # fmt: skip


def _tissue(fibre_branches, matrix_branches=0, n_fibres=1):
    d = np.eye(3)[:n_fibres]
    return TissueConfig(d, [0.5 / n_fibres] * n_fibres, 0.5, 1000.0, fibre=fibre_law("hgo"),
                        fibre_branches=fibre_branches, matrix_branches=matrix_branches)  # fmt: skip


def test_counts():
    t = _tissue(3)
    names = set(t.param_names)
    (r,) = branch_ridges(t, names)
    assert r.pairs == (("rel1_2", "gamma1_2"), ("rel1_3", "gamma1_3")) and r.flat == 2
    (r,) = branch_ridges(t, names - {"gamma1_2"})
    assert r.pairs == (("rel1_3", "gamma1_3"),) and r.flat == 1
    assert branch_ridges(t, names - {"gamma1_2", "gamma1_3"}) == []
    assert branch_ridges(t, names - {"gamma1_2", "rel1_3"}) == []
    assert branch_ridges(_tissue(2), set(_tissue(2).param_names) - {"k1_1"}) == []  # a fixed modulus takes one
    assert branch_ridges(_tissue(1), set(_tissue(1).param_names)) == []  # the paper's one branch: none
    t = _tissue(2, matrix_branches=2, n_fibres=2)
    found = branch_ridges(t, set(t.param_names))
    assert [r.pairs for r in found] == [(("rel_m_2", "gamma_m_2"),), (("rel1_2", "gamma1_2"),),
                                        (("rel2_2", "gamma2_2"),)]  # fmt: skip
    assert "fixed = { gamma_m_2 = 0.75 }" in found[0].note()


def _along(p, gamma2):
    """``p`` moved along the ridge to the second branch's viscous fraction ``gamma2``: the equilibrium modulus
    k (1 + r2), the amplitudes k gamma1 / (1 - gamma1), k r2 gamma2 / (1 - gamma2) and the times
    (1 - gamma_i) / beta_i kept."""
    k, r2, g1, g2 = p["k1_1"], p["rel1_2"], p["gamma1"], p["gamma1_2"]
    g_inf, a1, a2 = k * (1 + r2), k * g1 / (1 - g1), k * r2 * g2 / (1 - g2)
    t1, t2 = (1 - g1) / p["beta1"], (1 - g2) / p["beta1_2"]
    k_new = g_inf - a2 * (1 - gamma2) / gamma2
    g1_new = a1 / (k_new + a1)
    return {**p, "k1_1": k_new, "rel1_2": a2 * (1 - gamma2) / gamma2 / k_new, "gamma1": g1_new,
            "gamma1_2": gamma2, "beta1": (1 - g1_new) / t1, "beta1_2": (1 - gamma2) / t2}  # fmt: skip


@pytest.mark.parametrize("gamma2", [0.6, 0.75, 0.95])
def test_likelihood_flat_along_the_ridge(gamma2):
    """The tendon relaxation's force along the ridge moves by less than 1e-4 of its peak (measured 0.006-0.014 mN
    of 1602 mN, the time-discrete update's departure from the continuous series at dt 0.25 s; the data's noise sd is
    5 mN), while gamma2 moved alone moves it by more than the noise sd."""
    exp = load_experiment(TENDON)
    names = exp.tissue.param_names

    def force(p):
        return simulate(exp, np.array([p[n] for n in names]), full=True).force_mN[0]

    f0 = force(TRUTH)
    assert np.max(np.abs(force(_along(TRUTH, gamma2)) - f0)) < 1e-4 * np.max(f0)
    assert np.max(np.abs(force({**TRUTH, "gamma1_2": gamma2}) - f0)) > 5.0


def test_a_fixed_rate_takes_the_direction_away():
    """With a further branch's rate fixed its time follows its viscous fraction: no flat direction (a fixed rate of
    the first branch likewise)."""
    t = _tissue(2)
    names = set(t.param_names)
    assert branch_ridges(t, names - {"beta1_2"}) == []
    assert branch_ridges(t, names - {"beta1"}) == []
    (r,) = branch_ridges(_tissue(3), set(_tissue(3).param_names) - {"beta1_2"})
    assert r.pairs == (("rel1_3", "gamma1_3"),) and r.flat == 1


def _second_branch_creep():
    """The paper's T1 creep with a second Kelvin branch on family 2 (family 4), its parameters and names."""
    exp = load_experiment(ROOT / "data" / "T1.toml")
    exp = replace(exp, tissue=with_second_branch(exp.tissue, [2]))
    p = np.array(PAPER_PARAMETERS["T1"], dtype=float)
    g, c, b = p[5:8]
    p[5:8] = 2 * g, c, b  # the slow branch: half the fraction, twice the modulus
    return exp, np.concatenate([p, [0.6 * g, 0.6, 0.05]])


def test_second_branch_counts():
    exp, _ = _second_branch_creep()
    names = set(exp.tissue.param_names)
    assert exp.tissue.param_names[11:] == ("ginf4", "gamma4", "beta4")
    (r,) = branch_ridges(exp.tissue, names)
    assert r.pairs == (("ginf4", "gamma4"),) and r.flat == 1
    assert "gamma4 = 0.75" in r.note()
    assert branch_ridges(exp.tissue, names - {"gamma4"}) == []
    assert branch_ridges(exp.tissue, names - {"beta2"}) == []
    # the mirror ties carried to the second branches (family 3 takes 2): one direction, family 2's
    t = with_second_branch(load_experiment(ROOT / "data" / "T1.toml").tissue, [2, 3])
    tied = {"ginf3", "gamma3", "beta3", "ginf5", "gamma5", "beta5"}
    (r,) = branch_ridges(t, set(t.param_names) - tied)
    assert r.pairs == (("ginf4", "gamma4"),) and r.flat == 1


@pytest.mark.parametrize("gamma_b", [0.75, 0.9])
def test_second_branch_flat_along_the_ridge(gamma_b):
    """T1's displacement along the two-branch fibre's ridge (equilibrium g_a + g_b, both amplitudes and both times
    kept) moves by less than 1/40 of the data's noise sd (0.02 mm; measured 1.0e-4 to 2.0e-4 mm, the time-discrete
    update's departure), while gamma_b moved alone moves it by more than 1/4 of it (measured 0.009-0.027 mm)."""
    exp, p = _second_branch_creep()
    (ga, ca, ba), (gb, cb, bb) = p[5:8], p[11:14]
    amp_a, amp_b = ga * ca / (1 - ca), gb * cb / (1 - cb)
    g_b = amp_b * (1 - gamma_b) / gamma_b
    c_a = amp_a / (ga + gb - g_b + amp_a)
    q = p.copy()
    q[5:8] = ga + gb - g_b, c_a, (1 - c_a) / ((1 - ca) / ba)
    q[11:14] = g_b, gamma_b, (1 - gamma_b) / ((1 - cb) / bb)
    d0 = simulate(exp, p)
    assert np.max(np.abs(simulate(exp, q) - d0)) < exp.noise_sd_mm / 40
    alone = p.copy()
    alone[12] = gamma_b
    assert np.max(np.abs(simulate(exp, alone) - d0)) > exp.noise_sd_mm / 4
