"""Answers in a tissue's terms: the moduli, stresses and relaxation a posterior implies, with intervals.

A lab compares tissues by the moduli it reads off a test, not by a fibre phase's :math:`g_\\infty` or a Prony
branch's :math:`\\gamma`. For every draw of the material parameters this module runs two virtual uniaxial tests of
the fitted tissue (its laws, fractions and directions), stretch-controlled along the loading axis x to the stated
nominal strain :math:`\\varepsilon^*` with the lateral faces free:

* **instantaneous**: every Prony branch unrelaxed. A step to a held strain loads branch i of a law to
  :math:`r_i \\sigma_e / (1 - \\gamma_i)` (:mod:`~bayestissue.mechanics.laws.prony`), so the instantaneous tissue is the
  elastic one with each law's moduli multiplied by :math:`\\sum_i r_i / (1 - \\gamma_i)`;
* **equilibrium**: every branch relaxed, each to :math:`r_i \\sigma_e`: the moduli multiplied by :math:`\\sum_i r_i`.

The stress of a law is linear in its moduli at fixed exponents (the parameters of role ``modulus``), so both are
elastic solves of the same kernel. From them: the nominal stress :math:`P_{11}(\\varepsilon^*)`, the secant modulus
:math:`P_{11}/\\varepsilon^*` and the tangent modulus :math:`dP_{11}/d\\varepsilon` at :math:`\\varepsilon^*`
(central difference over :math:`\\pm 2\\,\\%` of :math:`\\varepsilon^*`), instantaneous and equilibrium; the
relaxation a full hold at :math:`\\varepsilon^*` gives, :math:`100\\,(1 - P_{eq}/P_{inst})` %; and each branch's
relaxation time :math:`t_i = (1 - \\gamma_i)/\\beta_i` (s). Without branches the tissue is elastic: the two tests
coincide and no time is reported. The fibres' tension-only switch and a recruitment stretch act as in any solve:
below the recruitment stretch the fibres carry nothing, which is why a modulus is stated at a strain.

:math:`\\varepsilon^*` defaults to the experiment's largest nominal strain (its observed displacement over
:math:`L_x`, or its prescribed stretch).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.mechanics import ForwardModel
from bayestissue.mechanics.protocols import protocol_from_mapping

__all__ = ["TissueTerms", "peak_strain", "tissue_terms"]

#: Steps of each virtual stretch ramp; the tangent's relative half-step.
N_RAMP, REL_STEP = 8, 0.02


@dataclass(frozen=True)
class TissueTerms:
    """Per quantity (name -> (unit, values over the draws)); ``strain`` the stated nominal strain; ``n_failed`` draws
    whose virtual test did not solve (NaN, left out of the intervals)."""

    strain: float
    values: dict
    n_failed: int = 0

    def rows(self, level: float = 0.9) -> list[dict]:
        a = (1.0 - level) / 2.0
        out = []
        for name, (unit, v) in self.values.items():
            lo, med, hi = np.nanquantile(v, [a, 0.5, 1.0 - a]) if np.isfinite(v).any() else (np.nan,) * 3
            out.append({"quantity": name, "unit": unit, "median": float(med), "lower": float(lo), "upper": float(hi)})
        return out

    def markdown(self) -> str:
        """A table: median and 90 % interval over the draws, or the value where there is one parameter set (the
        least-squares optimum of a run without sampling)."""
        n = len(next(iter(self.values.values()))[1])
        failed = f", {self.n_failed} failed solves left out" if self.n_failed else ""
        where = f"median and 90 % interval over {n} posterior draws{failed}" if n > 1 else f"one parameter set{failed}"
        lines = [f"Tissue terms at nominal strain {self.strain:.4g} (virtual uniaxial stretch along x; {where})", ""]
        if n > 1:
            lines += ["| quantity | unit | median | 90 % interval |", "|---|---|---|---|"]
            lines += [f"| {r['quantity']} | {r['unit']} | {r['median']:.4g} | [{r['lower']:.4g}, {r['upper']:.4g}] |"
                      for r in self.rows()]  # fmt: skip
        else:
            lines += ["| quantity | unit | value |", "|---|---|---|"]
            lines += [f"| {r['quantity']} | {r['unit']} | {r['median']:.4g} |" for r in self.rows()]
        return "\n".join(lines) + "\n"


def peak_strain(experiment) -> float:
    """The experiment's largest nominal strain along x: observed displacement over :math:`L_x`, else its prescribed
    stretch minus one."""
    if experiment.displacement_mm is not None:
        return float(np.max(np.abs(experiment.displacement_mm))) / experiment.specimen_mm[0]
    stretch = getattr(experiment.protocol, "stretch", None)
    if stretch is not None:
        return float(np.max(np.abs(np.asarray(stretch, dtype=float) - 1.0)))
    if "stretch" in experiment.columns:
        return float(np.max(np.abs(experiment.columns["stretch"] - 1.0)))
    raise ValidationError(f"{experiment.name}: strain", None, "a displacement or stretch to state the moduli at")


def _groups(tissue) -> list[tuple[str, int, tuple[str, ...]]]:
    """(branch suffix, number of branches, the moduli the branches scale) of the matrix and each fibre family."""
    specs = {p.name: p for p in tissue.parameters}
    n_m = tissue.matrix.n_parameters
    out = [("_m", tissue.matrix_branches, tuple(n for n in tissue.param_names[:n_m] if specs[n].role == "modulus"))]
    for k in range(1, tissue.n_fibres + 1):
        law = tissue.family_parameters(k)[: tissue.fibre.n_parameters]
        out.append((str(k), tissue.fibre_branches, tuple(n for n in law if specs[n].role == "modulus")))
    return out


def _multipliers(tissue, x: dict) -> tuple[dict, dict, dict]:
    """Per modulus name the instantaneous and equilibrium multipliers (module docstring); per branch its
    relaxation time (s)."""
    inst, eq, times = {}, {}, {}
    for suffix, nb, moduli in _groups(tissue):
        n = next(iter(x.values())).shape[0]
        mi, me = np.zeros(n), np.zeros(n)
        for i in range(1, nb + 1):
            tag = suffix if i == 1 else f"{suffix}_{i}"
            r = 1.0 if i == 1 else x[f"rel{tag}"]
            g, b = x[f"gamma{tag}"], x[f"beta{tag}"]
            mi, me = mi + r / (1.0 - g), me + r
            times[f"relaxation time t{tag}"] = (1.0 - g) / b
        if nb == 0:
            mi, me = np.ones(n), np.ones(n)
        for name in moduli:
            inst[name], eq[name] = mi, me
    return inst, eq, times


def tissue_terms(experiment, params: np.ndarray, *, strain: float | None = None) -> TissueTerms:
    """The tissue terms (module docstring) of ``experiment``'s tissue over the full material parameter rows
    ``params`` (n, n_material_total), at nominal ``strain`` (default :func:`peak_strain`)."""
    tissue = experiment.tissue
    P = np.atleast_2d(np.asarray(params, dtype=float))
    if P.shape[1] != tissue.n_parameters:
        raise ValidationError("params", P.shape, f"(n, {tissue.n_parameters}) rows of {tissue.param_names}")
    eps = peak_strain(experiment) if strain is None else float(strain)
    if not (np.isfinite(eps) and 0.0 < eps < 2.0):
        raise ValidationError(f"{experiment.name}: strain", eps, "a nominal strain in (0, 2)")
    x = {n: P[:, j] for j, n in enumerate(tissue.param_names)}
    inst, eq, times = _multipliers(tissue, x)
    elastic = replace(tissue, matrix_branches=0, fibre_branches=0)
    at = eps * np.array([1.0 - REL_STEP, 1.0, 1.0 + REL_STEP])
    area = experiment.specimen_mm[1] * experiment.specimen_mm[2]
    t = np.linspace(0.0, 1.0, N_RAMP + 1)
    models = [ForwardModel(replace(experiment, tissue=elastic, time_s=t, dt_s=t[1], displacement_mm=None,
                                   force_mN=None, stress_kpa=None, columns={}, meta={},
                                   protocol=protocol_from_mapping({"kind": "stretch_ramp", "stretch": 1.0 + a,
                                                                   "ramp_s": 1.0})))
              for a in at]  # fmt: skip
    out = {}
    for label, mult in (("instantaneous", inst), ("equilibrium", eq)):
        rows = np.stack([x[n] * mult.get(n, 1.0) for n in elastic.param_names], axis=1)
        # nominal P11 (kPa) at the end of each ramp: force (mN) over the reference section (mm^2); elastic, so the
        # path to the strain does not matter
        s = np.stack([fm(rows)[:, -1] / area for fm in models], axis=1)
        out[f"stress at strain ({label})"] = ("kPa", s[:, 1])
        out[f"secant modulus ({label})"] = ("kPa", s[:, 1] / eps)
        out[f"tangent modulus ({label})"] = ("kPa", (s[:, 2] - s[:, 0]) / (at[2] - at[0]))
    p_i, p_e = out["stress at strain (instantaneous)"][1], out["stress at strain (equilibrium)"][1]
    with np.errstate(divide="ignore", invalid="ignore"):
        out["relaxation at full hold"] = ("%", np.where(p_i > 0, 100.0 * (1.0 - p_e / p_i), np.nan))
    for name, v in times.items():
        out[name] = ("s", v)
    failed = int(np.sum(~np.isfinite(p_i) | ~np.isfinite(p_e)))
    return TissueTerms(eps, out, failed)
