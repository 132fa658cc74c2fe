"""The likelihood with one unit-cube coordinate integrated out by quadrature: importance sampling of a thin sheet.

Where a posterior is a curved sheet far thinner across one direction than along it, the importance proposal of
:mod:`~bayestissue.inference.sampling.importance` (a Student-t mixture in logit coordinates) tiles it with gaps and a
few draws in the gaps hold nearly all the weight. On the joint data set's full model the sheet is about 2e-4 thick
in logit units across a direction mostly along kappa (the Hessian of :math:`\\log L` at the heaviest draws:
largest eigenvalue 2.1-2.5e7, the next 0.6-1.4e5, docs/verification.md, stop 75), and 48 components left Pareto
:math:`\\hat k` at 0.98. Integrating that coordinate :math:`u_k` out exactly, per point, leaves (unit-cube prior,
:math:`z = \\operatorname{logit} u`, :math:`\\sigma` the logistic function)

.. math:: L_c(u_{-k}) = \\int_0^1 L(u)\\,du_k = \\int_{-\\infty}^{\\infty} e^{g(z_k)}\\,dz_k, \\qquad
   g(z_k) = \\log L(u_{-k}, \\sigma(z_k)) + \\log\\sigma(z_k) + \\log\\sigma(-z_k),

and :math:`Z = \\int_{[0,1]^{d-1}} L_c\\,du_{-k}`, which importance sampling estimates over the remaining
:math:`d - 1` coordinates, where the marginal posterior is many times thicker (Rao-Blackwellisation: conditioning
lowers the variance of the weights, Casella & Robert 1996, Biometrika 83, 81; Robert & Casella 2004, *Monte Carlo
Statistical Methods*, section 4.2).

The inner integral, per point, in three steps (all points of a batch at once, so each step is one batched call):

1. **Bracket.** :math:`z_k` is predicted from :math:`z_{-k}` by a quadratic regression fitted to posterior draws
   (:func:`fit_line`), and :math:`g` is evaluated on ``grid`` points across ``predicted +- window``; the best
   becomes the start. The window must hold the conditional peak: the regression's largest residual over the draws
   it was fitted to is reported (:attr:`LineQuadrature.residual_max`) and the window is at least 1.5 times it.
   Where exchanging two groups of the other coordinates leaves the likelihood unchanged (``swap``: the full model's
   fibre families 2 and 3) and :math:`k` is in neither, the conditional peak is the same at :math:`z_{-k}` and at
   its mirror image, so the regression is fitted to and evaluated at points folded onto one copy (the draws a
   proposal is fitted to may hold one copy only, and a proposal symmetrised over the exchange draws both: without
   the fold, the first run on the joint full model put 46 % of its points' peaks on the bracket's edge, holding 14 %
   of the weight). Where the best point is on the bracket's edge, the peak lies beyond it: up to ``rebracket`` more
   brackets of ``grid`` points, each centred on the edge the last one hit and twice as wide. A proposal's draws
   away from the posterior can have their peak far from the prediction: on the joint full model, of 100 draws of
   the fitted proposal whose first bracket (+-0.07) missed, the peak lay 0.069-1.5 away, and the 40 heaviest draws
   had one peak within +-0.5, 0.0002-0.026 from the prediction (stop 76). Then ``zoom`` finer grids, each of
   ``grid`` points across :math:`\\pm` one spacing of the last around its best point: where the conditional is far
   narrower than the bracket's spacing (T1's full model: its conditional sd in the softer fibre family's
   :math:`z_\\beta` is a small fraction of the 0.04 spacing of the +-0.81 bracket its regression's residuals need),
   the Newton steps' first differences, 0.3 of the spacing wide, straddle the peak and throw the point away; on 3 000
   draws of T1's fitted proposal, :math:`g'' \\ge 0` after the steps at 1 442 points without finer grids, at 3 with
   two (docs/verification.md, stop 77).
2. **Newton.** ``newton`` steps :math:`z_k \\leftarrow z_k - g'/g''` from central differences of step
   :math:`h = 0.3\\,s` (:math:`s = (-g'')^{-1/2}`, the conditional sd), each step clipped to :math:`\\pm 20 h`;
   where :math:`g'' \\ge 0`, a step of :math:`20 h` uphill; the first :math:`h` is 0.3 of the last bracket's
   spacing.
3. **Gauss-Hermite** with ``nodes`` nodes :math:`x_i` and weights :math:`w_i` centred on the peak :math:`m`:

   .. math:: \\int e^{g}\\,dz \\approx \\sqrt 2\\, s \\sum_i w_i\\, e^{g(m + \\sqrt 2 s x_i) + x_i^2},

   exact when :math:`g` is quadratic, i.e. the conditional Gaussian in :math:`z_k` (Davis & Rabinowitz 1984,
   *Methods of Numerical Integration*, 2.7). On the joint full model 12 nodes agree with a 801-point trapezoid over
   :math:`\\pm 12 s` to 1.4e-7 in :math:`\\log L_c` (8 posterior points; :math:`g` drops 61 nats at
   :math:`\\pm 12 s`, against 72 for a Gaussian).

**One labelling.** Where the coordinate to integrate out belongs to one of two exchangeable groups (the full model's
fibre families 2 and 3), the sheet is thin across the *softer* family's :math:`\\beta`, which is family 2's in one
labelling and family 3's in the other. With ``labelling = (a, b)`` (indices among the other coordinates of the two
groups' keys) only points with :math:`z_a \\ge z_b` are integrated and the others have zero likelihood, without a
call; the likelihood and the box prior are symmetric under the exchange, so that region holds half the evidence and
:math:`\\log 2` is added inside it (the ordered prior's factor :math:`n!` of :mod:`bayestissue.inference.ordering`).
The regression is fitted to draws folded onto that labelling (by the caller,
:func:`~bayestissue.inference.ordering.folded`).

A point whose peak lands on the last bracket's edge or whose :math:`g''` is not negative after the Newton steps is
counted (:attr:`LineQuadrature.edge`, :attr:`LineQuadrature.flat`): there the quadrature may miss mass, and the
estimate is only as good as those counts are small. Cost: ``(1 + zoom) grid + 3 newton + nodes`` likelihood calls
a point (41 + 18 + 12 = 71 by default, 153 with two finer grids), and ``grid`` more for each re-bracket: a draw
costs about 70-150 of the plain estimator's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.special import expit, log_expit, logsumexp

from bayestissue._validation import ValidationError
from bayestissue.inference.ordering import folded
from bayestissue.inference.sampling.importance import unit_logit

__all__ = ["LineQuadrature", "fit_line"]


#: The central-difference stencil of the Newton steps, in units of their step h.
_STENCIL = np.array([-1.0, 0.0, 1.0])


def _features(z_rest: np.ndarray) -> np.ndarray:
    """The quadratic regression's design matrix: 1, each coordinate and its square."""
    return np.column_stack([np.ones(z_rest.shape[0]), z_rest, z_rest**2])


@dataclass
class LineQuadrature:
    """:math:`\\log L_c` (module docstring) of a batched unit-cube log-likelihood over the coordinates but ``k``.
    ``coef``: the quadratic regression predicting :math:`z_k` (:func:`fit_line`) from the other coordinates, folded
    over ``swap`` (two index groups among them, or None); ``residual_max`` its largest residual over the draws it
    was fitted to; ``window``, ``grid``, ``rebracket``, ``newton``, ``nodes`` the three steps' settings.
    ``zoom`` the finer grids after the brackets; ``labelling`` the two keys' indices of one labelling (module
    docstring) or None. ``edge``, ``flat``, ``points``: points whose peak was on a bracket's edge after the
    re-brackets, whose :math:`g''` stayed non-negative, and all points integrated, counted over every call;
    ``outside``: points outside the labelling (zero likelihood, no call); ``calls`` the likelihood calls they
    took; ``doubtful``: per call, which of its points were either (:meth:`last_doubtful`); ``peak``: per call, each
    point's conditional peak and sd (NaN off the labelling; :meth:`last_peaks`)."""

    k: int
    coef: np.ndarray
    residual_max: float
    window: float = 0.06
    grid: int = 41
    newton: int = 6
    nodes: int = 12
    rebracket: int = 4
    zoom: int = 0
    swap: tuple | None = None
    labelling: tuple[int, int] | None = None
    edge: int = field(default=0, init=False)
    flat: int = field(default=0, init=False)
    points: int = field(default=0, init=False)
    outside: int = field(default=0, init=False)
    calls: int = field(default=0, init=False)
    doubtful: list = field(default_factory=list, init=False, repr=False)
    peak: list = field(default_factory=list, init=False, repr=False)

    def __post_init__(self):
        for name, ok, expected in (("window", self.window >= 1.5 * self.residual_max,
                                    f">= 1.5 times the regression's largest residual, {1.5 * self.residual_max:.3g}"),
                                   ("grid", self.grid >= 3, "an integer >= 3"), ("newton", self.newton >= 1, ">= 1"),
                                   ("nodes", self.nodes >= 2, ">= 2"), ("rebracket", self.rebracket >= 0, ">= 0"),
                                   ("zoom", self.zoom >= 0, ">= 0")):  # fmt: skip
            if not ok:
                raise ValidationError(f"line quadrature {name}", getattr(self, name), expected)

    def predict(self, z_rest: np.ndarray) -> np.ndarray:
        """The regression's :math:`z_k` at ``z_rest`` ``(n, d - 1)`` (folded over ``swap`` first)."""
        return _features(z_rest if self.swap is None else folded(z_rest, self.swap)) @ self.coef

    def full(self, z_rest: np.ndarray, z_k: np.ndarray) -> np.ndarray:
        """Unit-cube points ``(n, d)`` from ``z_rest`` ``(n, d - 1)`` and ``z_k`` ``(n,)``, both logit."""
        return expit(np.insert(z_rest, self.k, z_k, axis=1))

    def _g(self, log_l_unit: Callable, z_rest: np.ndarray, z_k: np.ndarray) -> np.ndarray:
        """The log integrand :math:`g` (module docstring) at the points ``z_rest`` ``(n, d - 1)`` with ``z_k``
        ``(n,)``: non-finite log-likelihoods (failed solves) count as zero likelihood. One batched call."""
        self.calls += z_k.size
        ll = np.asarray(log_l_unit(self.full(z_rest, z_k)), dtype=float)
        return np.where(np.isfinite(ll), ll, -np.inf) + log_expit(z_k) + log_expit(-z_k)

    def _bracket(self, log_l_unit, z_rest, centre, half) -> tuple[np.ndarray, np.ndarray]:
        """The best of ``grid`` points across ``centre +- half`` per point, and whether it lay on the bracket's edge
        (or nowhere finite)."""
        n = z_rest.shape[0]
        offsets = np.linspace(-1.0, 1.0, self.grid)[None, :] * half[:, None]
        f = self._g(log_l_unit, np.repeat(z_rest, self.grid, axis=0), (centre[:, None] + offsets).ravel())
        f = f.reshape(n, self.grid)
        best = np.argmax(f, axis=1)
        edge = (best == 0) | (best == self.grid - 1) | ~np.isfinite(f[np.arange(n), best])
        return centre + offsets[np.arange(n), best], edge

    def peaks(self, log_l_unit: Callable, z_rest: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Steps 1-2: per point the conditional peak :math:`m`, sd :math:`s`, whether the peak still lay on a
        bracket's edge after the re-brackets, and whether :math:`g''` stayed non-negative."""
        n = z_rest.shape[0]
        half = np.full(n, self.window)
        m, edge = self._bracket(log_l_unit, z_rest, self.predict(z_rest), half)
        for _ in range(self.rebracket):  # centred on the edge it hit, twice as wide
            if not edge.any():
                break
            i = np.flatnonzero(edge)
            half[i] *= 2.0
            m[i], edge[i] = self._bracket(log_l_unit, z_rest[i], m[i], half[i])
        for _ in range(self.zoom):  # a finer grid across +- one spacing of the last, around its best point
            half = 2.0 * half / (self.grid - 1)
            m, _ = self._bracket(log_l_unit, z_rest, m, half)
        h = 0.3 * 2.0 * half / (self.grid - 1)
        for _ in range(self.newton):
            f = self._g(log_l_unit, np.repeat(z_rest, 3, axis=0), (m[:, None] + h[:, None] * _STENCIL).ravel())
            f = f.reshape(n, 3)
            with np.errstate(invalid="ignore"):
                d1 = (f[:, 2] - f[:, 0]) / (2 * h)
                d2 = (f[:, 2] - 2 * f[:, 1] + f[:, 0]) / h**2
            concave = np.isfinite(d1) & np.isfinite(d2) & (d2 < 0)
            d2 = np.where(concave, d2, -1.0)
            step = np.where(concave, -d1 / d2, 20 * h * np.sign(np.nan_to_num(d1)))
            m = m + np.clip(step, -20 * h, 20 * h)
            s = np.where(concave, 1.0 / np.sqrt(-d2), h)
            h = np.clip(0.3 * s, 1e-8, half)
        return m, s, edge, ~concave

    def inside(self, z_rest: np.ndarray) -> np.ndarray:
        """Which points ``z_rest`` ``(n, d - 1)`` lie on the :attr:`labelling` (all without one)."""
        if self.labelling is None:
            return np.ones(z_rest.shape[0], dtype=bool)
        a, b = self.labelling
        return z_rest[:, a] >= z_rest[:, b]

    def __call__(self, log_l_unit: Callable, unit_rest: np.ndarray) -> np.ndarray:
        """:math:`\\log L_c` at unit-cube points ``unit_rest`` ``(n, d - 1)`` (step 3); with a :attr:`labelling`,
        :math:`\\log 2 + \\log L_c` on it and :math:`-\\infty` off it."""
        z_all = unit_logit(unit_rest)
        inside = self.inside(z_all)
        z_rest, n = z_all[inside], int(inside.sum())
        out, doubtful = np.full(z_all.shape[0], -np.inf), np.zeros(z_all.shape[0], dtype=bool)
        peak = np.full((z_all.shape[0], 2), np.nan)
        if n:
            m, s, edge, flat = self.peaks(log_l_unit, z_rest)
            x, w = np.polynomial.hermite.hermgauss(self.nodes)
            nodes = (m[:, None] + np.sqrt(2.0) * s[:, None] * x[None, :]).ravel()
            g = self._g(log_l_unit, np.repeat(z_rest, self.nodes, axis=0), nodes).reshape(n, self.nodes)
            log_2 = 0.0 if self.labelling is None else np.log(2.0)  # the other labelling's half (module docstring)
            out[inside] = np.log(np.sqrt(2.0) * s) + logsumexp(g + x[None, :] ** 2, b=w[None, :], axis=1) + log_2
            doubtful[inside] = edge | flat
            peak[inside] = np.column_stack([m, s])
            self.edge += int(edge.sum())
            self.flat += int(flat.sum())
        self.points += n
        self.outside += z_all.shape[0] - n
        self.doubtful.append(doubtful)
        self.peak.append(peak)
        return out

    def collapsed(self, log_l_unit: Callable) -> Callable[[np.ndarray], np.ndarray]:
        """:math:`\\log L_c` as a batched log-likelihood of the ``d - 1`` other unit-cube coordinates (what
        :func:`~bayestissue.inference.sampling.importance.importance_evidence` takes)."""
        return lambda unit_rest: self(log_l_unit, unit_rest)

    @staticmethod
    def _last(per_call: list, n: int) -> np.ndarray:
        """The last ``n`` points' entries (in order) of a per-call list."""
        got = sum(len(x) for x in per_call)
        if got < n:
            raise ValidationError("line quadrature points", got, f"at least the {n} asked for")
        return np.concatenate(per_call)[got - n :]

    def last_doubtful(self, n: int) -> np.ndarray:
        """Which of the last ``n`` points evaluated (in order) were doubtful: for an importance estimate's own
        draws, whose weights then say how much of the estimate rests on them."""
        return self._last(self.doubtful, n)

    def last_peaks(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The conditional peak :math:`m` and sd :math:`s` of the last ``n`` points evaluated (in order; NaN off the
        labelling): what :meth:`draw_at` needs for an importance estimate's own draws, without new calls."""
        peak = self._last(self.peak, n)
        return peak[:, 0], peak[:, 1]

    def draw_at(self, unit_rest: np.ndarray, m: np.ndarray, s: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Full unit-cube points ``(n, d)``: each of ``unit_rest`` with :math:`z_k` drawn from its conditional,
        taken as Gaussian :math:`N(m, s^2)` (what the quadrature assumes; for posterior quantiles of :math:`u_k`)."""
        return self.full(unit_logit(unit_rest), m + s * rng.standard_normal(np.shape(m)))

    def draw(self, log_l_unit: Callable, unit_rest: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """:meth:`draw_at` with each point's peak and sd found anew (steps 1-2)."""
        m, s, _, _ = self.peaks(log_l_unit, unit_logit(unit_rest))
        return self.draw_at(unit_rest, m, s, rng)

    def text(self) -> str:
        """One line: the settings and the counts."""
        zoom = f", {self.zoom} finer grids" if self.zoom else ""
        off = f" ({self.outside} draws off the labelling: no calls)" if self.labelling is not None else ""
        return (f"{self.grid}-point bracket of +-{self.window:.3g} (largest regression residual "
                f"{self.residual_max:.3g}; at most {self.rebracket} re-brackets){zoom}, {self.newton} Newton steps, "
                f"{self.nodes} Gauss-Hermite nodes: peak on the bracket's edge at {self.edge} of {self.points} "
                f"points{off}, not concave at {self.flat}")  # fmt: skip


def fit_line(unit_draws, weights, k: int, *, swap=None, n: int = 20_000, seed: int = 0, **settings) -> LineQuadrature:
    """The :class:`LineQuadrature` of coordinate ``k`` whose predictor is a quadratic least-squares regression of
    :math:`z_k` on the other logit coordinates (folded over ``swap``, two index groups among those ``d - 1``, when
    given), fitted to ``n`` draws resampled (multinomially, ``seed``) from the weighted posterior draws
    ``unit_draws`` ``(N, d)``; ``settings`` pass on (window, grid, newton, nodes, rebracket, zoom, labelling: with a
    labelling, the draws must lie on it)."""
    u = np.asarray(unit_draws, dtype=float)
    w = np.asarray(weights, dtype=float)
    if u.ndim != 2 or not 0 <= k < u.shape[1] or w.shape != (u.shape[0],) or not np.isclose(w.sum(), 1.0):
        raise ValidationError("line quadrature draws", f"shape {u.shape}, k {k}, weights {w.shape}",
                              "(N, d) unit points, 0 <= k < d and N weights summing to one")  # fmt: skip
    idx = np.random.default_rng(seed).choice(u.shape[0], size=n, p=w / w.sum())
    z = unit_logit(u[idx])
    rest = np.delete(z, k, axis=1)
    x = _features(rest if swap is None else folded(rest, swap))
    coef, *_ = np.linalg.lstsq(x, z[:, k], rcond=None)
    residual = float(np.max(np.abs(z[:, k] - x @ coef)))
    if "window" not in settings:
        settings["window"] = max(0.06, 1.5 * residual)
    return LineQuadrature(k=k, coef=coef, residual_max=residual, swap=swap, **settings)
