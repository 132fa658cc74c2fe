"""The two-branch (two-time-constant) fibre law of bayestissue/mechanics/branches.py."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.mechanics import (
    PAPER_TISSUE,
    CreepProtocol,
    Experiment,
    ForwardModel,
    TissueConfig,
    load_experiment,
    simulate,
)
from bayestissue.mechanics.branches import branch_relaxation, second_branch_ties, with_second_branch
from bayestissue.mechanics.protocols import StretchRampProtocol
from bayestissue.paper import MIRROR_TIES, PAPER_PARAMETERS

AXIAL = TissueConfig(directions=[[1.0, 0.0, 0.0]], phi_fibres=[0.3], phi_matrix=0.7)
SPEC = (5.0, 2.0, 3.0)  # mm; cross-section 6 mm^2
T1 = Path(__file__).resolve().parents[2] / "data" / "T1.toml"


def _relaxation(dt):
    time = np.arange(0.0, 600.0 + 1e-9, 5.0)
    return Experiment("relax", SPEC, StretchRampProtocol(stretch=1.1, ramp_s=dt), time, dt, tissue=AXIAL)


def test_equal_branches_are_the_paper_fibre():
    e = _relaxation(1.0)
    two = replace(e, tissue=with_second_branch(AXIAL, [1]))
    law = [10.0, 0.6, 0.002]
    one = simulate(e, np.array([1.0, 2.0, *law]))
    both = simulate(two, np.array([1.0, 2.0, *law, *law]))
    # the same stress summed in two halves: round-off only
    np.testing.assert_allclose(both, one, rtol=1e-12, atol=1e-12)


def test_relaxation_converges_to_the_two_term_prony_series():
    """A fibre along x does not enter the lateral equations under stretch control, so the fibre share of P11 is the
    run minus the same run with both moduli zero; it must approach the continuous closed form as dt -> 0 (the
    stretch is applied over one step, so the error is first order in dt)."""
    p = np.array([1.0, 2.0, 10.0, 0.6, 0.002, 30.0, 0.5, 0.2])  # slow (t = 200 s) and fast (t = 2.5 s) branch
    p0 = p.copy()
    p0[[2, 5]] = 0.0
    lam = 1.1
    errors = []
    for dt in (1.0, 0.25, 0.0625):
        e = replace(_relaxation(dt), tissue=with_second_branch(AXIAL, [1]))
        fibre = (simulate(e, p) - simulate(e, p0)) / (SPEC[1] * SPEC[2]) / lam / 0.15
        exact = branch_relaxation(e.time_s, (lam**2 - 1) / 2, [10.0, 30.0], [0.6, 0.5], [0.002, 0.2])
        errors.append(np.max(np.abs(fibre[1:] - exact[1:]) / exact[1:]))
    assert errors[0] < 0.02  # measured 0.016 at t = 5 s = 2 fast relaxation times; 9e-4 at dt = 1/16 s
    assert errors[1] < errors[0] / 3.5 and errors[2] < errors[1] / 3.5  # first order: 4x per dt / 4 (measured 4.3, 4.1)


def test_sensitivities_of_the_second_branch_match_differences():
    """Creep of the paper's T1 specimen with branches on families 2 and 3: the exact sensitivities against central
    differences (step 1e-6 relative; truncation ~1e-12, round-off ~1e-16 / 1e-6 of the displacement)."""
    tissue = with_second_branch(load_experiment(T1).tissue, [2, 3])
    e = Experiment("creep", (5.33, 2.43, 3.9), CreepProtocol(10.6), np.arange(0.0, 1201.0, 30.0), 6.0, tissue=tissue)
    p = np.concatenate([PAPER_PARAMETERS["T1"], [20.0, 0.4, 0.05, 20.0, 0.4, 0.05]])
    y, dy = ForwardModel(e).sensitivities(p)
    for j in range(p.size):
        h = 1e-6 * p[j]
        up, dn = p.copy(), p.copy()
        up[j] += h
        dn[j] -= h
        fd = (simulate(e, up) - simulate(e, dn)) / (2 * h)
        np.testing.assert_allclose(dy[:, j], fd, rtol=1e-5, atol=1e-7 * np.max(np.abs(dy[:, j])) + 1e-12)


def test_experiment_file_key(tmp_path):
    base = load_experiment(T1)
    text = T1.read_text() + "\n[tissue]\nsecond_branch = [2, 3]\n"
    (tmp_path / "T1.toml").write_text(text)
    (tmp_path / "T1.csv").write_text(T1.with_suffix(".csv").read_text())
    e = load_experiment(tmp_path / "T1.toml")
    assert e.tissue.n_fibres == 5 and e.tissue.second_branch == (2, 3)
    np.testing.assert_allclose(e.tissue.directions[3:], base.tissue.directions[1:])
    np.testing.assert_allclose(e.tissue.phi_fibres, [0.2, 0.1, 0.1, 0.1, 0.1])
    for bad, word in (("[4]", "1..3"), ("[2, 2]", "each family once"), ("[1.5]", "1..3")):
        (tmp_path / "T1.toml").write_text(text.replace("[2, 3]", bad))
        with pytest.raises(ValidationError, match="second_branch") as err:
            load_experiment(tmp_path / "T1.toml")
        assert word in str(err.value)


def test_ties_follow_the_branches():
    ties = second_branch_ties(MIRROR_TIES, with_second_branch(PAPER_TISSUE, [2, 3]))
    assert set(ties) - set(MIRROR_TIES) == {("ginf5", "ginf4"), ("gamma5", "gamma4"), ("beta5", "beta4")}
    assert second_branch_ties(MIRROR_TIES, with_second_branch(PAPER_TISSUE, [2])) == MIRROR_TIES
