"""Every homogeneous load case against its incompressible closed form (Treloar's and Ogden's formulas) at a bulk
modulus 10^5 times the shear modulus, for the neo-Hookean, Mooney-Rivlin and Ogden matrices; bad modes refused."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.mechanics import Experiment, ForwardModel, TissueConfig, load_case, matrix_law
from bayestissue.mechanics.loadcases import Biaxial, Equibiaxial, PureShear, SimpleShear, Uniaxial
from bayestissue.mechanics.protocols import (
    CreepProtocol,
    MeasuredForceProtocol,
    MeasuredStretchProtocol,
    ShearRampProtocol,
    StretchRampProtocol,
)

SPEC = (4.0, 2.0, 1.0)  # mm
#: bulk modulus, 10^7 times the small-strain shear moduli below: the compressible model's distance from the
#: incompressible closed form is of the order of the stress (tangent) over K
BULK = 3e7
T = np.linspace(0.0, 10.0, 21)
LAWS = {
    "neo_hookean": ({}, [3.0], lambda x: [(3.0, 2.0)]),
    "mooney_rivlin": ({}, [3.0, 1.5], lambda x: [(3.0, 2.0), (1.5, -2.0)]),
    "ogden1": ({"terms": 1}, [2.0, -9.0], lambda x: [(2.0, -9.0)]),
    "ogden2": ({"terms": 2}, [1.0, 4.0, 0.5, -3.0], lambda x: [(1.0, 4.0), (0.5, -3.0)]),
}


def _tissue(name):
    opts, _, _ = LAWS[name]
    law = matrix_law("ogden" if name.startswith("ogden") else name, **opts)
    return TissueConfig(np.zeros((0, 3)), [], 1.0, BULK, matrix=law)


def _ogden_terms(name):
    """(mu_p, alpha_p) of the law as an Ogden series (Mooney-Rivlin: alpha = 2 and -2, mu_2 = kappa)."""
    return LAWS[name][2](None)


def _closed_form(mode, terms, x):
    """Incompressible nominal stress P_1 (P_12 for simple shear) of sum_p 2 mu_p / alpha_p^2 (sum lambda^alpha - 3)."""
    out = np.zeros_like(x)
    for mu, a in terms:
        c = 2.0 * mu / a
        if mode == "uniaxial":
            out += c * (x ** (a - 1) - x ** (-a / 2 - 1))
        elif mode == "equibiaxial":
            out += c * (x ** (a - 1) - x ** (-2 * a - 1))
        elif mode == "pure_shear":
            out += c * (x ** (a - 1) - x ** (-a - 1))
        else:
            lp = np.sqrt(1 + x**2 / 4) + x / 2
            out += c * (lp**a - lp**-a) / (lp + 1 / lp)
    return out


def _run(tissue, case, peak, columns=None):
    if isinstance(case, SimpleShear):
        prot = ShearRampProtocol(shear=peak, ramp_s=10.0)
    else:
        prot = StretchRampProtocol(stretch=peak, ramp_s=10.0)
    columns = dict(columns or {})
    stress = columns.pop("nominal_stress_kpa", None)  # a named field of the experiment
    exp = Experiment("x", SPEC, prot, T, 0.5, tissue=tissue, load_case=case, stress_kpa=stress, columns=columns)
    return exp, ForwardModel(exp)


@pytest.mark.parametrize("law", list(LAWS))
@pytest.mark.parametrize(
    ("mode", "peak"),
    [("uniaxial", 1.8), ("compression", 0.6), ("equibiaxial", 1.5), ("pure_shear", 1.6), ("simple_shear", 0.8)],
)
def test_load_case_matches_the_incompressible_closed_form(law, mode, peak):
    """Relative to the largest stress, within 1e-4: the compressible model approaches the incompressible one as
    (tangent modulus)/K -> 0; at K = 3e5 kPa the stiffest case (Ogden alpha = -9 in equibiaxial tension, 135 kPa)
    was 0.9 % off and the rest below 1.5e-4, at K = 3e7 kPa all are within 1e-4 (the error falls as 1/K)."""
    tissue = _tissue(law)
    case = {"uniaxial": Uniaxial(), "compression": Uniaxial(), "equibiaxial": Equibiaxial(),
            "pure_shear": PureShear(), "simple_shear": SimpleShear()}[mode]  # fmt: skip
    cols = {} if mode == "simple_shear" else {"nominal_stress_kpa": np.zeros(T.size)}
    if mode == "equibiaxial":
        cols["nominal_stress_2_kpa"] = np.zeros(T.size)
    exp, fm = _run(tissue, case, peak, cols)
    p = np.array(LAWS[law][1])
    y = fm(p)
    x = exp.protocol.shear_at(T) if mode == "simple_shear" else exp.protocol.stretch_at(T)
    P1 = y[:, 0] if y.ndim == 2 else y
    ref = _closed_form("uniaxial" if mode == "compression" else mode, _ogden_terms(law), x)
    np.testing.assert_allclose(P1, ref, rtol=0, atol=1e-4 * np.abs(ref).max())
    if mode == "equibiaxial":
        np.testing.assert_allclose(y[:, 1], y[:, 0], rtol=1e-10)  # the two faces alike (isotropic)
    if mode == "compression":
        assert np.all(P1[1:] < 0)


@pytest.mark.parametrize("law", list(LAWS))
def test_biaxial_with_two_stretch_histories_matches_the_closed_form(law):
    r"""Non-proportional planar biaxial loading (face 1 to 1.4 with face 2 held at 1, then face 2 to 1.25 with face 1
    held, then face 1 back to 1.1): both faces' nominal stresses against the incompressible closed form
    :math:`P_a = \lambda_a^{-1}\sum_p \tfrac{2\mu_p}{\alpha_p}(\lambda_a^{\alpha_p} - \lambda_3^{\alpha_p})`,
    :math:`\lambda_3 = 1/(\lambda_1\lambda_2)`, within 1e-4 of the largest stress (K = 1e7 mu, as above). The
    first leg is pure shear on face 1 (face 2's stress is then the planar-tension lateral stress, not zero)."""
    t = np.linspace(0.0, 30.0, 61)
    lam1 = np.interp(t, [0, 10, 20, 30], [1, 1.4, 1.4, 1.1])
    lam2 = np.interp(t, [0, 10, 20, 30], [1, 1, 1.25, 1.25])
    prot = MeasuredStretchProtocol(t, lam1, lam2)
    zeros = np.zeros(t.size)
    exp = Experiment("x", SPEC, prot, t, 0.5, tissue=_tissue(law), load_case=Biaxial(), stress_kpa=zeros,
                     columns={"nominal_stress_2_kpa": zeros})  # fmt: skip
    y = ForwardModel(exp)(np.array(LAWS[law][1]))
    lam3 = 1.0 / (lam1 * lam2)
    ref = np.zeros((t.size, 2))
    for mu, a in _ogden_terms(law):
        ref[:, 0] += 2.0 * mu / a * (lam1**a - lam3**a) / lam1
        ref[:, 1] += 2.0 * mu / a * (lam2**a - lam3**a) / lam2
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-4 * np.abs(ref).max())
    assert abs(ref[20, 1]) > 0.1 * np.abs(ref).max()  # the held face carries stress: the histories are independent


def test_a_second_stretch_history_needs_the_general_biaxial_case():
    """A stretch_2 or force_2_mN history with a load case that fixes face 2 (uniaxial, equibiaxial, pure shear, or
    biaxial with a ratio) is refused by name rather than ignored."""
    t = np.linspace(0.0, 10.0, 11)
    by_stretch = MeasuredStretchProtocol(t, np.linspace(1, 1.2, 11), np.linspace(1, 1.1, 11))
    by_force = MeasuredForceProtocol(t, np.linspace(0, 5, 11), np.linspace(0, 3, 11))
    for case in (Uniaxial(), Equibiaxial(), PureShear(), Biaxial(ratio=0.5)):
        for prot in (by_stretch, by_force):
            if not case.controls or prot.controls not in case.controls:
                continue
            with pytest.raises(ValidationError, match=r"'biaxial' without a ratio .*got 'a second load history"):
                Experiment("x", SPEC, prot, t, 0.5, tissue=_tissue("neo_hookean"), load_case=case)


def test_force_controlled_biaxial_is_the_inverse_of_the_stretch_controlled_one():
    """Equibiaxial dead loads taken from a stretch-controlled run give back its stretch on both faces (a moderate K:
    at K = 1e7 mu the step-size stop of the Newton loop leaves ~4e-6 relative, conditioning, not the load case)."""
    from dataclasses import replace

    tissue = replace(_tissue("mooney_rivlin"), bulk_kpa=3000.0)
    p = np.array(LAWS["mooney_rivlin"][1])
    exp, fm = _run(tissue, Equibiaxial(), 1.4, {"nominal_stress_kpa": np.zeros(T.size)})
    P = fm(p)[:, 0]
    load = np.interp(exp.step_time_s, T, P)
    force = Experiment("f", SPEC, _Measured(exp.step_time_s, load), T, 0.5, tissue=tissue, load_case=Biaxial())
    u = ForwardModel(force)(p)
    lam = exp.protocol.stretch_at(T)
    np.testing.assert_allclose(u[:, 0], (lam - 1) * SPEC[0], rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(u[:, 1], (lam - 1) * SPEC[1], rtol=1e-6, atol=1e-9)


def test_force_controlled_biaxial_with_two_load_histories_is_the_inverse():
    """The two faces' forces of a stretch-controlled run with two stretch histories (face 1 to 1.3 with face 2 held,
    then face 2 to 1.2), fed back as two measured force histories (a force_2_mN column), return both faces'
    stretches (moderate K as above: 1e-6 relative, the Newton loop's step-size stop)."""
    from dataclasses import replace

    tissue = replace(_tissue("mooney_rivlin"), bulk_kpa=3000.0)
    p = np.array(LAWS["mooney_rivlin"][1])
    t = np.linspace(0.0, 20.0, 41)
    lam1, lam2 = np.interp(t, [0, 10, 20], [1, 1.3, 1.3]), np.interp(t, [0, 10, 20], [1, 1, 1.2])
    stretch = Experiment("s", SPEC, MeasuredStretchProtocol(t, lam1, lam2), t, 0.5, tissue=tissue,
                         load_case=Biaxial())  # fmt: skip
    forces = ForwardModel(stretch)(p)  # (n, 2) mN: face 1 and face 2
    assert [c.column for c in stretch.channels] == ["force_mN", "force_2_mN"]
    force = Experiment("f", SPEC, MeasuredForceProtocol(t, forces[:, 0], forces[:, 1]), t, 0.5, tissue=tissue,
                       load_case=Biaxial())  # fmt: skip
    u = ForwardModel(force)(p)
    np.testing.assert_allclose(u[:, 0], (lam1 - 1) * SPEC[0], rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(u[:, 1], (lam2 - 1) * SPEC[1], rtol=1e-6, atol=1e-9)
    ratio = Experiment("r", SPEC, MeasuredForceProtocol(t, forces[:, 0]), t, 0.5, tissue=tissue, load_case=Biaxial())
    assert np.abs(ForwardModel(ratio)(p)[:, 1] - u[:, 1]).max() > 0.1  # without the second column: the ratio's load


class _Measured(CreepProtocol):
    """A dead-load history given on the step grid (for the round trip above)."""

    def __init__(self, t, p):
        object.__setattr__(self, "stress_kpa", 0.0)
        object.__setattr__(self, "_t", t)
        object.__setattr__(self, "_p", p)

    def nominal_stress_kpa(self, time_s, area_mm2):
        return np.interp(time_s, self._t, self._p)


def test_modes_are_refused_by_name_and_by_control():
    with pytest.raises(ValidationError, match=r"protocol mode: expected one of .*'equibiaxal'.*did you mean"):
        load_case("equibiaxal")
    tissue = _tissue("neo_hookean")
    with pytest.raises(ValidationError, match=r"protocol mode 'simple_shear': expected a protocol controlling shear"):
        Experiment("x", SPEC, StretchRampProtocol(1.2, 5.0), T, 0.5, tissue=tissue, load_case=SimpleShear())
    with pytest.raises(ValidationError, match=r"protocol mode 'pure_shear': expected a protocol controlling stretch"):
        Experiment("x", SPEC, CreepProtocol(5.0), T, 0.5, tissue=tissue, load_case=PureShear())
    with pytest.raises(ValidationError, match=r"protocol ratio: expected a finite number"):
        Biaxial(ratio=float("nan"))
