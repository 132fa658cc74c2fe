"""The laws in time: every law and load case against the independent per-step root solve, Prony relaxation against
its closed-form series, the special cases that must give the paper's numbers, and exact sensitivities."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bayestissue.mechanics import Experiment, ForwardModel, TissueConfig, fibre_law, load_experiment, matrix_law
from bayestissue.mechanics.branches import with_second_branch
from bayestissue.mechanics.loadcases import Biaxial, Equibiaxial, SimpleShear, Uniaxial
from bayestissue.mechanics.protocols import (
    CreepProtocol,
    MeasuredStretchProtocol,
    ShearRampProtocol,
    StretchRampProtocol,
)
from bayestissue.mechanics.reference import reference_laws_simulate
from bayestissue.paper import PAPER_BOUNDS, PAPER_PARAMETERS

ROOT = Path(__file__).resolve().parents[2]
SPEC = (5.0, 2.0, 3.0)
T = np.arange(0.0, 60.0 + 1e-9, 2.0)
#: a non-proportional biaxial path: face 1 stretched to 1.25 in 20 s with face 2 held, then face 2 to 1.15 in 20 s
#: with face 1 held, then both held (relaxation)
SEQUENTIAL = MeasuredStretchProtocol(T, np.interp(T, [0, 20, 60], [1, 1.25, 1.25]),
                                     np.interp(T, [0, 20, 40, 60], [1, 1, 1.15, 1.15]))  # fmt: skip
V2 = (np.cos(0.35), np.sin(0.35), 0.0)


def _exp(tissue, protocol, case, dt=1.0, stress=True):
    """An experiment without data; ``stress`` observes the nominal stress (kPa) rather than the force."""
    data = np.zeros(T.size) if stress and not isinstance(case, SimpleShear) else None
    return Experiment("x", SPEC, protocol, T, dt, tissue=tissue, load_case=case, stress_kpa=data)


#: (tissue, protocol, load case, parameters): every law, with and without branches, every kind of control
CASES = {
    "ogden+branch, biaxial stretch (ratio 0.5)": (
        TissueConfig(np.zeros((0, 3)), [], 1.0, 500.0, matrix=matrix_law("ogden"), matrix_branches=1),
        StretchRampProtocol(1.3, 20.0), Biaxial(ratio=0.5), [2.0, -6.0, 0.6, 0.05],
    ),
    "ogden(2) + 2 branches, biaxial with two stretch histories": (
        TissueConfig(np.zeros((0, 3)), [], 1.0, 500.0, matrix=matrix_law("ogden", terms=2), matrix_branches=2),
        SEQUENTIAL, Biaxial(), [2.0, 5.0, 0.5, -4.0, 0.6, 0.3, 0.5, 0.4, 0.02],
    ),
    "neo-Hookean + hgo(recruitment, 2 branches), uniaxial stretch": (
        TissueConfig([[1, 0, 0], V2], [0.2, 0.2], 0.6, 300.0, matrix=matrix_law("neo_hookean"),
                     fibre=fibre_law("hgo", recruitment=True), fibre_branches=2),
        StretchRampProtocol(1.15, 10.0), Uniaxial(),
        [1.5] + [10.0, 3.0, 0.08, 1.02, 0.6, 0.2, 0.5, 0.4, 0.02] * 2,
    ),
    "mooney-rivlin + linear(3 branches), equibiaxial": (
        TissueConfig([[1, 0, 0], [0, 1, 0]], [0.25, 0.15], 0.6, 800.0, fibre_branches=3),
        StretchRampProtocol(1.12, 10.0), Equibiaxial(),
        [2.0, 1.0] + [20.0, 0.5, 0.1, 2.0, 0.7, 0.02, 0.5, 0.3, 1.0] * 2,
    ),
    "yeoh + 2 matrix branches, simple shear": (
        TissueConfig(np.zeros((0, 3)), [], 1.0, 500.0, matrix=matrix_law("yeoh"), matrix_branches=2),
        ShearRampProtocol(0.6, 20.0), SimpleShear(), [2.0, -0.2, 0.05, 0.5, 0.1, 1.5, 0.8, 0.01],
    ),
    "mooney-rivlin + hgo(branch), creep (force control)": (
        TissueConfig([V2, [V2[0], -V2[1], 0.0]], [0.2, 0.2], 0.6, 300.0, fibre=fibre_law("hgo")),
        CreepProtocol(4.0), Uniaxial(), [1.0, 2.0] + [15.0, 2.0, 0.1, 0.7, 0.05] * 2,
    ),
}  # fmt: skip


@pytest.mark.parametrize("name", list(CASES))
def test_kernel_matches_the_independent_reference(name):
    """The compiled time loop against an independent integration (complex-step stresses of the laws' NumPy
    energies, NumPy Prony branches, scipy root per step) at every step, to 1e-7 of the largest value: both converge
    to ~1e-11 in strain; the Ogden kernel's eigenvalues and the reference's complex step differ at round-off. (The
    Ogden case is biaxial at ratio 0.5: in uniaxial tension two principal stretches are equal, where the reference's
    closed-form eigenvalues are not analytic and the complex step fails; the kernel's Jacobi rotations do not care.)"""
    tissue, protocol, case, p = CASES[name]
    exp = _exp(tissue, protocol, case)
    fm = ForwardModel(exp)
    out = fm._run(np.array([p], dtype=float), False, False)[0][0]
    ref = reference_laws_simulate(exp, p)
    assert np.all(np.isfinite(ref)) and np.all(np.isfinite(out))
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-7 * np.abs(ref).max())


@pytest.mark.parametrize("name", list(CASES))
def test_exact_sensitivities_match_central_differences(name):
    """Every parameter, every data time: the exact derivatives against central differences of the forward model
    (step 1e-5 of the parameter, relative; truncation ~1e-10, the solves' tolerance ~1e-11 / 1e-5 in the
    difference), to 2e-5 of each column's largest value. A fibre switching between tension and slack makes the
    derivative one-sided at isolated parameter values; none lies within the steps used here."""
    tissue, protocol, case, p = CASES[name]
    fm = ForwardModel(_exp(tissue, protocol, case))
    p = np.array(p, dtype=float)
    y, dy = fm.sensitivities(p)
    for j in range(p.size):
        h = 1e-5 * max(abs(p[j]), 1e-3)
        up, dn = p.copy(), p.copy()
        up[j] += h
        dn[j] -= h
        fd = (fm(up) - fm(dn)) / (2 * h)
        scale = max(np.abs(fd).max(), np.abs(dy[..., j]).max(), 1e-12)
        np.testing.assert_allclose(dy[..., j], fd, rtol=0, atol=2e-5 * scale, err_msg=f"{name}: {fm.names[j]}")


def test_prony_relaxation_matches_the_closed_form_series():
    """Simple shear held from the first step (every strain prescribed): each matrix branch relaxes as
    r_i [1 + gamma_i / (1 - gamma_i) exp(-t / t_i)], t_i = (1 - gamma_i) / beta_i, times the elastic shear stress.
    The discrete update treats the jump at t = 0 as if half a step later: first order in dt (measured relative errors
    0.024, 0.012, 0.0059 at dt = 0.2, 0.1, 0.05 s: orders 1.03 and 1.01; the fastest branch relaxes in 0.6 s).
    Asserted: the order within 0.15 of 1 at the finest two steps, the error below 0.01 at dt = 0.05 s."""
    p = [3.0, 0.6, 0.2, 2.0, 0.8, 0.05, 0.5, 0.4, 1.0]  # mu; gamma1, beta1; r2, gamma2, beta2; r3, gamma3, beta3
    tissue = TissueConfig(np.zeros((0, 3)), [], 1.0, 1e4, matrix=matrix_law("neo_hookean"), matrix_branches=3)
    gamma, r = 0.3, np.array([1.0, 2.0, 0.5])
    g, b = np.array([0.6, 0.8, 0.4]), np.array([0.2, 0.05, 1.0])
    t_i = (1 - g) / b
    errs = []
    for dt in (0.2, 0.1, 0.05):
        t = np.arange(0.0, 40.0 + 1e-9, 0.2)
        exp = Experiment("x", SPEC, ShearRampProtocol(gamma, dt), t, dt, tissue=tissue, load_case=SimpleShear())
        out = ForwardModel(exp)(p)
        closed = 3.0 * gamma * np.sum(r * (1 + g / (1 - g) * np.exp(-t[:, None] / t_i)), axis=1)
        errs.append(np.abs(out[1:] - closed[1:]).max() / closed[1:].max())
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert errs[-1] < 0.01 and abs(orders[-1] - 1) < 0.15, (errs, orders)


def test_two_branches_are_the_two_branch_fibre_law():
    """Prony with relative modulus r on the linear fibre, g = g_a / 2 and r = g_b / g_a, is the two-branch law of
    mechanics/branches.py (two half-fraction families on one direction): the same numbers to 1e-12."""
    base = load_experiment(ROOT / "data" / "T1.toml")
    two = replace(base, tissue=with_second_branch(base.tissue, [2, 3]))
    ga, gb = 13.4, 27.0
    pa = np.array(PAPER_PARAMETERS["T1"], dtype=float)
    p_two = np.concatenate([pa[:5], [2 * ga, 0.891, 5.6e-4, 2 * ga, 0.891, 4.3e-4], [2 * gb, 0.7, 0.05] * 2])
    prony = replace(base, tissue=replace(base.tissue, fibre_branches=2))
    fam = [[ga, 0.891, b, gb / ga, 0.7, 0.05] for b in (5.6e-4, 4.3e-4)]
    fam1 = [pa[2] / 2, pa[3], pa[4], 1.0, pa[3], pa[4]]  # family 1: two equal half branches, the paper's fibre
    p_prony = np.concatenate([pa[:2], fam1, fam[0], fam[1]])
    np.testing.assert_allclose(ForwardModel(prony)(p_prony), ForwardModel(two)(p_two), rtol=1e-12, atol=1e-14)


def test_the_paper_model_is_bitwise_the_frozen_kernel():
    """The paper's laws through the plug-in time loop give the same bits as the kernel before the laws became
    plug-ins (benchmarks/legacy_kernel.py), on T1 and T2 and 60 parameter sets from the Table 1 box (failed solves
    included: the same sets fail)."""
    from bayestissue.mechanics.fibres import fibre_structure
    from benchmarks.legacy_kernel import legacy_solve_uniaxial_batch

    rng = np.random.default_rng(5)
    lo, hi = PAPER_BOUNDS.T
    P = np.exp(rng.uniform(np.log(lo), np.log(hi), (60, 11)))
    P[:, 3::3] = rng.uniform(lo[3], hi[3], (60, 3))
    P = np.ascontiguousarray(np.vstack([PAPER_PARAMETERS["T1"], PAPER_PARAMETERS["T2"], P]))
    for name in ("T1", "T2"):
        e = load_experiment(ROOT / "data" / f"{name}.toml")
        fm, t = ForwardModel(e), e.tissue
        new = fm._run(P, False, False)[0][:, :, 0]
        old = np.empty((P.shape[0], fm.load.size))
        ok = np.empty(P.shape[0], dtype=bool)
        legacy_solve_uniaxial_batch(P, fibre_structure(t.directions), np.ascontiguousarray(t.phi_fibres),
                                    t.phi_matrix, t.bulk_kpa, np.ascontiguousarray(t.eps0), fm.load, e.dt_s,
                                    e.specimen_mm[0], old, ok, np.empty((1, 1, 6)), np.empty((1, 1, 3)), False,
                                    np.zeros(P.shape[0], dtype=np.int64), False)  # fmt: skip
        assert np.array_equal(new, old, equal_nan=True)
