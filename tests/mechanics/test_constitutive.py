"""Stress and consistent tangent of the composite (matrix + penalty + Kelvin fibres)."""

import numpy as np
import pytest

from bayestissue.mechanics import PAPER_TISSUE
from bayestissue.mechanics.composite import composite_stress_tangent, workspace
from bayestissue.mechanics.fibres import fibre_structure
from bayestissue.mechanics.kinematics import from_voigt, to_voigt
from bayestissue.mechanics.reference import reference_stress

M = fibre_structure(PAPER_TISSUE.directions)
PHI = np.ascontiguousarray(PAPER_TISSUE.phi_fibres)
EPS0 = np.zeros(3)
MU, KAPPA, PHI_M, K = 2.0, 3.0, 0.4, 1000.0
GINF = np.array([30.0, 10.0, 20.0])
C_K = np.array([0.5, 0.3, 0.8])


PARAMS = np.array([MU, KAPPA, *np.column_stack([GINF, [0.5] * 3, [1.0] * 3]).ravel()])  # gamma, beta: only c, q act


def stress(e, q, *, load=0.0, tangent=False):
    """The composite's stress (minus a dead load P11 = ``load`` on face x) with fixed Kelvin constants ``C_K`` and
    history terms ``q`` (one branch per family)."""
    S, D, e = np.empty(6), np.empty((6, 6)), np.asarray(e, float)
    fs = np.stack([C_K[:, None], np.asarray(q, float)[:, None], np.empty((3, 1))])  # c, q, tau (written)
    ms = np.stack([np.ones((1, 6)), np.zeros((1, 6)), np.empty((1, 6))])  # no matrix branch: c, q, tau
    J = composite_stress_tangent(e, PARAMS, PAPER_TISSUE.layout, M, PHI, PHI_M, K, EPS0, ms, fs, S, D, tangent,
                                 workspace())  # fmt: skip
    tau = fs[2]
    assert J > 0
    c11 = 1.0 + 2.0 * e[0]  # the dead load as the solver adds it (mechanics/solver.py, kind 1)
    S[0] -= load / np.sqrt(c11)
    if tangent:
        D[0, 0] += load * c11**-1.5
    return S, D, tau[:, 0]


def fd_tangent(e, q, h=1e-6):
    D = np.empty((6, 6))
    for j in range(6):
        ep, em = e.copy(), e.copy()
        ep[j] += h
        em[j] -= h
        D[:, j] = (stress(ep, q)[0] - stress(em, q)[0]) / (2 * h)
    return D


def test_zero_stress_at_zero_strain():
    S, _, tau = stress(np.zeros(6), np.zeros(3))
    np.testing.assert_array_equal(tau, 0.0)
    assert np.abs(S).max() < 1e-12


def test_stress_matches_independent_full_tensor_implementation_and_is_symmetric():
    rng = np.random.default_rng(0)
    q = np.array([0.5, -0.2, 0.1])
    for _ in range(5):
        E = from_voigt(rng.normal(0, 0.15, 6))
        S_ref, tau_ref = reference_stress(
            E,
            MU,
            KAPPA,
            PHI_M,
            K,
            PAPER_TISSUE.directions,
            PHI,
            lambda eps: np.maximum(0.0, (GINF * eps + q) / C_K),
        )
        np.testing.assert_allclose(S_ref, S_ref.T, rtol=0, atol=1e-12)
        S, _, tau = stress(to_voigt(E), q)
        np.testing.assert_allclose(S, to_voigt(S_ref), rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(tau, tau_ref, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("regime", ["tension", "compression", "mixed"])
def test_tangent_matches_central_differences(regime):
    """Analytic dS/dE against central differences (h = 1e-6, truncation ~1e-12 relative, round-off ~1e-10)."""
    rng = np.random.default_rng({"tension": 1, "compression": 2, "mixed": 3}[regime])
    q = {
        "tension": np.full(3, 5.0),
        "compression": np.full(3, -50.0),
        "mixed": np.array([5.0, -50.0, 0.0]),
    }[regime]
    for _ in range(5):
        e = rng.normal(0, 0.05, 6)
        S, D, tau = stress(e, q, load=3.0, tangent=True)
        if regime == "tension":
            assert np.all(tau > 0)
        elif regime == "compression":
            assert np.all(tau == 0)
        Dfd = fd_tangent(e, q)
        D0 = stress(e, q, tangent=True)[1]
        assert np.abs(D0 - Dfd).max() <= 1e-6 * np.abs(Dfd).max()


def test_dead_load_term_in_tangent():
    e = np.array([0.2, -0.1, -0.08, 0.01, 0.0, 0.0])
    q = np.zeros(3)
    D = stress(e, q, load=7.0, tangent=True)[1]
    Rp = stress(e + [1e-6, 0, 0, 0, 0, 0], q, load=7.0)[0]
    Rm = stress(e - [1e-6, 0, 0, 0, 0, 0], q, load=7.0)[0]
    np.testing.assert_allclose(D[:, 0], (Rp - Rm) / 2e-6, rtol=1e-6, atol=1e-6)


def test_tangent_on_either_side_of_the_tension_switch():
    """Put every fibre exactly at the switch (trial tension 0): the tangent is the compression branch there, and a
    one-sided difference towards tension picks up phi_k g_k / c_k M_k (M_k : d) of each fibre stretched by d."""
    e = np.array([0.05, -0.02, -0.02, 0.0, 0.0, 0.0])
    eps = M @ (e * [1, 1, 1, 2, 2, 2])
    q = -GINF * eps  # trial tension exactly zero for all fibres
    S, D, tau = stress(e, q, tangent=True)
    np.testing.assert_array_equal(tau, 0.0)
    h = 1e-5
    d = M[1] * [1, 1, 1, 2, 2, 2]  # direction that raises fibre 2's strain
    d /= np.linalg.norm(d)

    def f(a):
        return stress(e + a * d, q)[0]

    # second-order one-sided differences (error O(h^2)), each on one side of the kink
    fwd = (-3 * S + 4 * f(h) - f(2 * h)) / (2 * h)
    bwd = (3 * S - 4 * f(-h) + f(-2 * h)) / (2 * h)
    np.testing.assert_allclose(bwd, D @ d, rtol=1e-6, atol=1e-6)  # compression side = tangent at the switch
    rate = M @ (d * [1, 1, 1, 2, 2, 2])  # d eps_k along d; fibres with rate > 0 switch into tension
    assert rate[1] > 0
    jump = ((PHI * GINF / C_K * np.maximum(rate, 0.0))[:, None] * M).sum(axis=0)
    np.testing.assert_allclose(fwd - bwd, jump, rtol=1e-6, atol=1e-6)
    # a hair into tension the analytic tangent includes the fibre
    e_t = e + 1e-4 * d
    D_t = stress(e_t, q, tangent=True)[1]
    assert np.abs(D_t - fd_tangent(e_t, q, h=1e-7)).max() <= 1e-6 * np.abs(D_t).max()
