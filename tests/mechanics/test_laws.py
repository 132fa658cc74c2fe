"""The law-level checks, run on every registered law through the compiled kernels: zero stress in the reference
state, the stress is the strain energy's derivative (complex step of each law's independent NumPy energy), the
tangent is the stress's derivative (central differences), objectivity, the tension-only switch and the recruitment
stretch one-sided; docs/laws.md is generated from the registry."""

import itertools
import zlib
from pathlib import Path

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.mechanics import TissueConfig
from bayestissue.mechanics.composite import composite_energy, composite_stress_tangent, workspace
from bayestissue.mechanics.fibres import fibre_structure
from bayestissue.mechanics.kinematics import from_voigt, to_voigt
from bayestissue.mechanics.laws import FIBRE_LAWS, MATRIX_LAWS, fibre_law, laws_markdown, matrix_law

ROOT = Path(__file__).resolve().parents[2]
BULK = 2000.0  # kPa: a penalty of the order of the moduli, so that the volumetric part is exercised too
PHI_M = 0.6
V = np.array([0.8, 0.5, 0.33]) / np.linalg.norm([0.8, 0.5, 0.33])

#: every law with options worth checking, and parameter values inside their boxes
MATRICES = [
    ("mooney_rivlin", {}, [2.0, 3.0]),
    ("neo_hookean", {}, [2.5]),
    ("ogden", {"terms": 1}, [1.5, -7.0]),
    ("ogden", {"terms": 2}, [1.2, 3.5, 0.8, -2.5]),
    ("ogden", {"terms": 3}, [1.2, 3.5, 0.8, -2.5, 0.3, 6.0]),
    ("yeoh", {}, [2.0, -0.3, 0.05]),
]
FIBRES = [
    ("linear", {}, [30.0]),
    ("hgo", {}, [20.0, 2.0, 0.12]),
    ("hgo", {"recruitment": True}, [20.0, 2.0, 0.05, 1.03]),
]


def _matrix_state():
    """No matrix branch: c = 1, q = 0, tau written."""
    return np.stack([np.ones((1, 6)), np.zeros((1, 6)), np.empty((1, 6))])


def _fibre_state(nf):
    """One elastic branch per family: c = 1, q = 0, tau written."""
    return np.stack([np.ones((max(nf, 1), 1)), np.zeros((max(nf, 1), 1)), np.empty((max(nf, 1), 1))])


def _tissue(matrix=None, fibre=None, direction=V):
    """A matrix-only tissue of ``matrix`` (neo-Hookean fibres absent), or the paper's matrix with one elastic
    fibre family of ``fibre`` along ``direction``."""
    if fibre is None:
        return TissueConfig(np.zeros((0, 3)), [], 1.0, BULK, matrix=matrix, fibre_branches=0)
    return TissueConfig([direction], [1.0 - PHI_M], PHI_M, BULK, fibre=fibre, fibre_branches=0)


def _params(tissue, law_values, matrix_values=(2.0, 3.0)):
    return np.array(list(law_values) if tissue.n_fibres == 0 else list(matrix_values) + list(law_values))


def stress(tissue, p, e, tangent=True):
    S, D = np.empty(6), np.empty((6, 6))
    nf = tissue.n_fibres
    J = composite_stress_tangent(
        np.asarray(e, float), p, tissue.layout, fibre_structure(tissue.directions).reshape(-1, 6),
        np.asarray(tissue.phi_fibres), tissue.phi_matrix, tissue.bulk_kpa, np.zeros(nf), _matrix_state(),
        _fibre_state(nf), S, D, tangent, workspace(),
    )  # fmt: skip
    assert J > 0
    return S, D


def energy_reference(tissue, p, E):
    """The total strain energy of the composite from the laws' independent NumPy energies (complex E allowed)."""
    C = np.eye(3) + 2.0 * E
    J = np.sqrt(np.linalg.det(C))
    n_m = tissue.matrix.n_parameters
    total = tissue.phi_matrix * tissue.matrix.energy_reference(C, p[:n_m]) + 0.5 * tissue.bulk_kpa * (J - 1.0) ** 2
    for k in range(tissue.n_fibres):
        v = tissue.directions[k]
        fp = p[n_m : n_m + tissue.fibre.n_parameters]
        kap = fp[2] if tissue.fibre.name == "hgo" else 0.0
        H = kap * np.eye(3) + (1 - 3 * kap) * np.outer(v, v)
        total = total + tissue.phi_fibres[k] * tissue.fibre.energy_reference(np.sum(H * E), fp)
    return total


def _cases():
    for name, opts, vals in MATRICES:
        yield f"matrix-{name}-{opts}", _tissue(matrix=matrix_law(name, **opts)), vals
    for name, opts, vals in FIBRES:
        yield f"fibre-{name}-{opts}", _tissue(fibre=fibre_law(name, **opts)), vals


CASES = list(_cases())
IDS = [c[0] for c in CASES]


def test_every_registered_law_is_checked():
    assert {n for n, _, _ in MATRICES} == set(MATRIX_LAWS) and {n for n, _, _ in FIBRES} == set(FIBRE_LAWS)


@pytest.mark.parametrize(("name", "tissue", "vals"), CASES, ids=IDS)
def test_zero_stress_in_the_reference_state(name, tissue, vals):
    S, _ = stress(tissue, _params(tissue, vals), np.zeros(6))
    assert np.abs(S).max() < 1e-12


def _strains(rng, n=4, scale=0.12):
    """``n`` random Green strains (Voigt) whose C = I + 2E has eigenvalues above 0.2 (a draw below is skipped: the
    kernels refuse an inadmissible C)."""
    done = 0
    while done < n:
        e = rng.normal(0.0, scale, 6) + np.array([0.08, 0.02, -0.03, 0, 0, 0])
        if np.linalg.eigvalsh(np.eye(3) + 2.0 * from_voigt(e)).min() > 0.2:
            done += 1
            yield e


@pytest.mark.parametrize(("name", "tissue", "vals"), CASES, ids=IDS)
def test_stress_is_the_derivative_of_the_independent_energy(name, tissue, vals):
    """Complex step (h = 1e-30: no cancellation, exact to round-off) of the laws' NumPy energies against the kernel's
    stress, to 1e-9 of its largest component: the kernels' arithmetic and the eigenvalue paths differ at round-off,
    the Ogden Jacobi rotations converge to ~1e-15."""
    p = _params(tissue, vals)
    for e in _strains(np.random.default_rng(zlib.crc32(name.encode()))):
        S, _ = stress(tissue, p, e, tangent=False)
        E = from_voigt(e)
        ref = np.empty(6)
        for j in range(6):
            dE = np.zeros(6)
            dE[j] = 1.0
            h = 1e-30
            w = energy_reference(tissue, p, E + 1j * h * from_voigt(dE))
            ref[j] = w.imag / h / (1.0 if j < 3 else 2.0)  # a shear component perturbs E_ab and E_ba
        np.testing.assert_allclose(S, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


@pytest.mark.parametrize(("name", "tissue", "vals"), CASES, ids=IDS)
def test_tangent_matches_central_differences(name, tissue, vals):
    """Central differences (h = 1e-6: truncation ~1e-12, round-off ~1e-10 relative) to 1e-6 of the largest entry."""
    p = _params(tissue, vals)
    for e in _strains(np.random.default_rng(7)):
        _, D = stress(tissue, p, e)
        fd = np.empty((6, 6))
        for j in range(6):
            ep, em = e.copy(), e.copy()
            ep[j] += 1e-6
            em[j] -= 1e-6
            fd[:, j] = (stress(tissue, p, ep, False)[0] - stress(tissue, p, em, False)[0]) / 2e-6
        np.testing.assert_allclose(D, fd, rtol=0, atol=1e-6 * np.abs(fd).max())


@pytest.mark.parametrize(("name", "tissue", "vals"), CASES, ids=IDS)
def test_energy_is_the_potential_of_the_stress(name, tissue, vals):
    """The kernel's energy (the Newton loop's merit function) against the independent energy."""
    p = _params(tissue, vals)
    nf = tissue.n_fibres
    for e in _strains(np.random.default_rng(3)):
        w = composite_energy(
            e, p, tissue.layout, fibre_structure(tissue.directions).reshape(-1, 6), np.asarray(tissue.phi_fibres),
            tissue.phi_matrix, tissue.bulk_kpa, np.zeros(nf), _matrix_state(), _fibre_state(nf),
            workspace(),
        )  # fmt: skip
        assert w == pytest.approx(energy_reference(tissue, p, from_voigt(e)), rel=1e-10, abs=1e-12)


def _rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


@pytest.mark.parametrize(("name", "tissue", "vals"), CASES, ids=IDS)
def test_objectivity(name, tissue, vals):
    """Rotating the strain (and the fibres) rotates the stress: S(Q E Q^T; Q v) = Q S(E; v) Q^T."""
    p = _params(tissue, vals)
    rng = np.random.default_rng(11)
    for e in _strains(rng, n=3):
        Q = _rotation(rng)
        S, _ = stress(tissue, p, e, False)
        turned = tissue if tissue.n_fibres == 0 else _tissue(fibre=tissue.fibre, direction=Q @ V)
        S2, _ = stress(turned, p, to_voigt(Q @ from_voigt(e) @ Q.T), False)
        np.testing.assert_allclose(from_voigt(S2), Q @ from_voigt(S) @ Q.T, rtol=0, atol=1e-10 * np.abs(S).max())


@pytest.mark.parametrize(("name", "tissue", "vals"), CASES, ids=IDS)
def test_exchangeable_terms_give_the_same_stress(name, tissue, vals):
    """A law's exchangeable label group (the prior keeps one labelling of its terms and relabels points into it,
    inference.ordering.OrderedGroup) must be a true symmetry: every permutation of whole terms gives the kernel's
    stress to round-off (1e-12 of its largest component). Laws without such a group pass trivially."""
    p = _params(tissue, vals)
    names = list(tissue.param_names)
    groups = [terms for terms, exchangeable in tissue.label_groups if exchangeable]
    e = np.array([0.09, -0.02, -0.04, 0.03, -0.01, 0.02])
    S, _ = stress(tissue, p, e, False)
    for terms in groups:
        idx = np.array([[names.index(n) for n in t] for t in terms])
        for perm in itertools.permutations(range(len(terms))):
            q = p.copy()
            q[idx.ravel()] = p[idx[list(perm)].ravel()]
            np.testing.assert_allclose(stress(tissue, q, e, False)[0], S, rtol=0, atol=1e-12 * np.abs(S).max())


def test_label_groups_of_the_tissue():
    """Which terms a tissue's prior orders: Ogden terms by exponent (exchangeable), Prony branches by rate
    (branch 1 the fastest; not a permutation symmetry), per fibre family with the family's names."""
    assert _tissue(matrix=matrix_law("ogden", terms=3)).label_groups == (
        ((("alpha1", "mu1"), ("alpha2", "mu2"), ("alpha3", "mu3")), True),)  # fmt: skip
    assert _tissue(matrix=matrix_law("ogden", terms=1)).label_groups == ()
    t = TissueConfig([V, -V], [0.3, 0.3], 0.4, BULK, fibre=fibre_law("hgo"), fibre_branches=2, matrix_branches=3)
    assert t.label_groups == (
        ((("beta_m",), ("beta_m_2",), ("beta_m_3",)), False),
        ((("beta1",), ("beta1_2",)), False),
        ((("beta2",), ("beta2_2",)), False),
    )  # fmt: skip
    assert {n for g, _ in t.label_groups for term in g for n in term} <= set(t.param_names)


@pytest.mark.parametrize(("name", "opts", "vals"), FIBRES, ids=[f"{n}-{o}" for n, o, _ in FIBRES])
def test_fibres_carry_tension_only_and_recruit_one_sided(name, opts, vals):
    """Compressed along the fibre the family adds nothing (stress and tangent of the matrix alone); with a
    recruitment stretch it stays slack up to lambda_r and then rises from zero with zero slope (a toe)."""
    x = np.array([1.0, 0.0, 0.0])
    tissue = _tissue(fibre=fibre_law(name, **opts), direction=x)
    p = _params(tissue, vals)
    if name == "hgo":
        p[4] = 0.0  # no dispersion: the fibre strain is E11 alone
    p0 = p.copy()
    p0[2] = 0.0  # the fibre's modulus zero: the matrix alone

    def bare(e):
        return stress(tissue, p0, e)

    for e11 in (-0.05, -0.01):
        e = np.array([e11, -0.3 * e11, -0.3 * e11, 0, 0, 0])
        S, D = stress(tissue, p, e)
        S0, D0 = bare(e)
        np.testing.assert_array_equal(S, S0)
        np.testing.assert_array_equal(D, D0)
    if opts.get("recruitment"):
        lam_r = vals[3]
        er = 0.5 * (lam_r**2 - 1.0)
        below, above = stress(tissue, p, [er - 1e-4, 0, 0, 0, 0, 0]), stress(tissue, p, [er + 1e-4, 0, 0, 0, 0, 0])
        S0b, S0a = bare([er - 1e-4, 0, 0, 0, 0, 0])[0], bare([er + 1e-4, 0, 0, 0, 0, 0])[0]
        np.testing.assert_allclose(below[0], S0b, atol=1e-12)  # slack below the recruitment stretch
        extra = above[0][0] - S0a[0]
        assert 0 < extra < 1e-3 * vals[0]  # the toe: sigma = 4 k1 y exp(...), y = 1e-4


def test_laws_are_refused_by_name_with_the_nearest_one():
    with pytest.raises(ValidationError, match=r"tissue matrix: expected one of .*'ogdne'.*did you mean 'ogden'"):
        matrix_law("ogdne")
    with pytest.raises(ValidationError, match=r"tissue terms: expected a number of Ogden terms in 1..4, got 7"):
        matrix_law("ogden", terms=7)
    with pytest.raises(ValidationError, match=r"tissue terms: expected no such option for the hgo law, got 2 \(its "
                       r"options: recruitment\)"):  # fmt: skip
        fibre_law("hgo", terms=2)


def test_reference_is_rendered_from_the_registry():
    assert (ROOT / "docs" / "laws.md").read_text() == laws_markdown()
