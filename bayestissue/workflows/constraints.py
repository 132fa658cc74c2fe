"""Are the ties and fixed values of a calibration consistent with the data? A likelihood-ratio test by least squares.

A configuration that ties parameters (the mirror model: family 3 takes family 2's values) or holds some fixed is a
nested submodel of the model with every one of them released. A predictive check cannot see a wrong tie when the
tied model still fits; the likelihood ratio between the two least-squares optima can (Wilks 1938,
doi:10.1214/aoms/1177732360). With Gaussian noise,

.. math:: \\Lambda = \\sum_e \\frac{RSS_{e,c} - RSS_{e,f}}{\\sigma_e^2} \\quad (\\sigma_e \\text{ known}), \\qquad
          \\Lambda = \\sum_e n_e \\log\\frac{RSS_{e,c}}{RSS_{e,f}} \\quad (\\sigma_e \\text{ profiled out}),

for the constrained (c) and free (f) optima, each experiment e with its own noise sd, referred to
:math:`\\chi^2_{d}` with d the number of parameters released. The free fit starts at the constrained optimum (its
cost cannot be higher) and at the parameters' initial values. With the sd profiled out and several experiments the
least squares minimises the unweighted sum of RSS, not the profile likelihood, so :math:`\\Lambda` can come out
negative: it is then reported as 0 (the test cannot reject there; conservative). The :math:`\\chi^2`
reference is conservative where a released parameter is not identified or ends on its box's edge (the test then
understates the evidence against the constraints, never overstates it). Least squares only: seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.stats import chi2

from bayestissue.inference import LeastSquaresResult, fit_least_squares

__all__ = ["ConstraintTest", "constraint_test", "LEVEL"]

#: The test's level: constraints with p below it are reported as rejected.
LEVEL = 0.01


@dataclass(frozen=True)
class ConstraintTest:
    """The likelihood-ratio test of a calibration's ties and fixed values (module docstring)."""

    released: tuple[str, ...]
    df: int
    cost_constrained: float
    cost_free: float
    statistic: float
    p_value: float
    known_sd: bool

    @property
    def rejected(self) -> bool:
        return self.p_value < LEVEL

    def text(self) -> str:
        form = "sum (RSS_c - RSS_f) / sd^2" if self.known_sd else "sum n log(RSS_c / RSS_f)"
        head = (f"ties and fixed values ({', '.join(self.released)}) vs released: least-squares cost "
                f"{self.cost_constrained:.6g} vs {self.cost_free:.6g}, {form} = {self.statistic:.3g} on {self.df} df, "
                f"p = {self.p_value:.2g}")  # fmt: skip
        if self.rejected:
            return (f"{head}: REJECTED at the {LEVEL:g} level, the data ask for the released parameters (the "
                    "constrained posterior is then tight around a compromise; free them or compare the models' "
                    "evidence)")  # fmt: skip
        return f"{head}: not rejected at the {LEVEL:g} level"


def _rss(problem, x) -> np.ndarray:
    """Each experiment's raw residual sum of squares at the sampled material parameters ``x`` (natural units)."""
    preds = problem.predict_material(np.asarray(x, dtype=float)[None, :])
    return np.array([float(np.sum((p[0] - e.observed) ** 2)) for p, e in zip(preds, problem.experiments, strict=True)])


def constraint_test(experiments, config, problem, best: LeastSquaresResult) -> ConstraintTest | None:
    """The test of ``problem``'s ties and fixed values (built from ``experiments`` and ``config``) at its
    least-squares optimum ``best``; None when nothing is tied or fixed."""
    from bayestissue.workflows.problem import build_problem

    specs = problem.material.specs
    released = tuple(s.name for s in specs if s.fixed or s.tied_to is not None)
    if not released:
        return None
    free = build_problem(experiments, replace(config, tied={}, fixed=(), sampled=None))
    fm = free.material
    lo, hi = fm.lower, fm.upper
    start = np.clip(problem.material.expand(best.x), lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))
    fits = [fit_least_squares(free, x0=x0, max_nfev=config.ls_max_nfev, jacobian=config.ls_jacobian, space="unit")
            for x0 in (start, None)]  # fmt: skip
    fit = min(fits, key=lambda r: r.cost)
    rss_c = _rss(problem, best.x)
    # the free model contains the constrained optimum: where its fits end higher, that point is the free optimum
    # (one point for every experiment: clipping each experiment's RSS apart would mix two points and inflate Lambda)
    rss_f = _rss(free, fit.x) if fit.cost < best.cost else rss_c
    sds = [e.noise.sd for e in problem.experiments]
    known = all(sd is not None for sd in sds)
    if known:
        stat = float(sum((c - f) / sd**2 for c, f, sd in zip(rss_c, rss_f, sds, strict=True)))
    else:
        n = [e.observed.size for e in problem.experiments]
        stat = float(sum(k * np.log(c / f) for k, c, f in zip(n, rss_c, rss_f, strict=True) if f > 0))
    df = fm.n_sampled - problem.material.n_sampled
    return ConstraintTest(released, df, float(best.cost), float(min(fit.cost, best.cost)), max(stat, 0.0),
                          float(chi2.sf(max(stat, 0.0), df)), known)  # fmt: skip
