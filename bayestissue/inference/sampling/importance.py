"""The evidence by importance sampling from a proposal fitted to posterior draws: an estimator that does not compress.

Nested sampling estimates :math:`Z = \\int L(\\theta)\\,\\pi(\\theta)\\,d\\theta` by shrinking the prior shell by shell;
where its new points are not fair draws inside the contour (a thin curved ridge, a plateau whose parts the live points
settle on unevenly) every run can be wrong by more than its own error, and independent runs disagree
(docs/verification.md: the joint mirror model, log Z 911.4-917.2 over eight UltraNest runs). This module estimates
the same integral another way. In the nested engine's unit-cube coordinates :math:`u` (the prior transform
:math:`\\theta = T(u)`, so that the prior is uniform on :math:`[0, 1]^d`),

.. math:: Z = \\int_{[0,1]^d} L(T(u))\\,du = \\mathbb E_q\\Big[\\frac{L(T(u))}{q(u)}\\Big],
   \\qquad \\hat Z = \\frac1N \\sum_{i=1}^N w_i, \\quad w_i = \\frac{L(T(u_i))}{q(u_i)},\\ u_i \\sim q,

unbiased for any proposal :math:`q` that is positive wherever :math:`L > 0` (Owen 2013, *Monte Carlo theory, methods
and examples*, ch. 9). The proposal is a defensive mixture (Hesterberg 1995, Technometrics 37, 185)

.. math:: q(u) = \\alpha + (1 - \\alpha)\\, m(z)\\prod_j \\frac{1}{u_j (1 - u_j)}, \\qquad z = \\operatorname{logit} u,

the prior with share :math:`\\alpha` (so that :math:`q > 0` on the whole cube) and a Student-t mixture :math:`m` in
logit coordinates (:func:`~bayestissue.inference.proposals.fit_t_mixture`: EM, scales widened by 1.5, 5 degrees of
freedom) fitted to posterior draws (e.g. every nested run's, pooled: the union of what each run found). Adaptation
rounds then move the mixture towards the posterior by weighted EM on the proposal's own draws (population Monte
Carlo with a mixture proposal, Cappe, Douc, Guillin, Marin & Robert 2008, Stat. Comput. 18, 447: each round lowers
the Kullback-Leibler divergence of the proposal from the posterior): with :math:`\\omega_i` the normalised weights
and :math:`\\rho_{ik}` component :math:`k`'s responsibility for draw :math:`z_i` (Gaussian kernels of the fitted
moments),

.. math:: \\pi_k' = \\sum_i \\omega_i\\rho_{ik}, \\quad m_k' = \\frac{\\sum_i \\omega_i\\rho_{ik} z_i}{\\pi_k'}, \\quad
   C_k' = \\frac{\\sum_i \\omega_i\\rho_{ik} (z_i - m_k')(z_i - m_k')^T}{\\pi_k'},

each blended with the component's previous moments in proportion :math:`n_k / (n_k + n_0)` (:math:`n_k` the
component's effective number of draws, :math:`n_0 = d + 2`), so that a component few draws inform keeps its shape.
The weights point where the proposal lacks mass (on the joint mirror model: the slab of the posterior against
gamma2's upper bound, which the logit stretches into a long tail), and the rounds move components there. The
estimate uses only fresh draws of the last proposal, so it stays unbiased whatever the adaptation did.

Where the proposal is still poor, a few draws hold nearly all the weight (on the joint full model: Kish's effective
sample size 2-80 of 40 000 a round) and the EM step fits its components to those few points. ``em_clip`` offers the
remedy of nonlinear population Monte Carlo (Koblents & Miguez 2015, Stat. Comput. 25, 407): each round's EM uses
clipped weights, the ``em_clip`` largest lowered to the ``em_clip``-th largest, so that several hundred draws inform
the step; the estimate's weights are never clipped. It is off by default: on the evidence check's models, 200 of
40 000 clipped left the final Pareto :math:`\\hat k` of T1's mirror model where it was, kept the joint full model's
rounds at 0.63-0.90 (not below 0.7 to stay), and on T2's full model kept the rounds from converging in 40
(docs/verification.md, stop 73).

How many rounds: a round's estimate from a proposal that still lacks mass somewhere is low (the missing mass sits in
weights its draws rarely reach), so the rounds' estimates rise while the proposal improves and level off when it
has converged. The adaptation stops when the last ``adapt_patience`` rounds, each with Pareto :math:`\\hat k` below
0.7, have a median estimate at most ``adapt_tol`` above the median of the ``adapt_patience`` rounds before them, or
after ``adapt_rounds`` (then ``adapt_converged`` is false). Medians, because a single round can land high: with a
heavy tail by one large weight, and with a light one by chance (the joint mirror model's round 6: 916.14, its
converged rounds 915.5). A fixed count is not enough: on the joint data set's scale
model 8 rounds left the estimate still climbing (890.1 -> 904.0 over the rounds, final k-hat 2.21), 24 rounds
brought it to its plateau (918.8-919.1; final 918.86 +- 0.03, k-hat 0.32).

Its error: the draws are independent, so :math:`\\operatorname{Var}(\\hat Z)/Z^2 \\approx s_w^2 / (N \\bar w^2)`
(delta method; :math:`s_w` the weights' sd). That estimate is only as good as the weights' tail: the Pareto
:math:`\\hat k` of the largest weights (Vehtari et al. 2024, JMLR 25(72), "Pareto smoothed importance sampling",
arviz's ``psislw``) says whether the variance exists in practice, :math:`\\hat k < 0.7` needed. And, as for nested
runs, independent batches must agree with their own errors (:math:`\\chi^2` of their :math:`\\log\\hat Z` on
:math:`B - 1` degrees of freedom, :math:`p \\ge 0.01`).

What it cannot see: posterior mass where :math:`q` is negligible and where no draw falls (a mode no run found). Then
:math:`\\hat Z` is low and every diagnostic may pass; with the weights bounded by the defensive term, such a region
must hold less than about :math:`\\alpha^{-1} \\max_u L / (N Z)` of the evidence to stay unseen, which for a posterior
a few tens of nats above its prior is no bound at all. So it is a second opinion on the regions the runs found, not
a search for new ones: where it agrees with a nested run the run's compression was sound; where it is higher than a
run by more than both errors, that run lost mass; where it is lower, either the run over-compressed or the proposal
misses mass, and the Pareto :math:`\\hat k` and the batches are what tell.

A known symmetry of the likelihood is a mode no run needs to find. Where exchanging two parameter groups :math:`P`
leaves :math:`L` unchanged (the full model's fibre families 2 and 3, mirror images about the loading axis) and the
prior is the whole box, the posterior holds two mirror copies of equal mass, and a run that found one of them (the
joint full model's nautilus run: 99.99 % of its weight at ginf2 > ginf3) gives a proposal that misses half the
evidence, which only the defensive prior's rare draws reach, as huge weights. The proposal is then symmetrised,

.. math:: m_P(z) = \\tfrac12\\big(m(z) + m(Pz)\\big),

with :math:`m` fitted to the draws folded onto one copy (:math:`u_{a_0} \\ge u_{b_0}`), and each EM round fits the
tied mixture of the :math:`2K` components :math:`(m_k, C_k)` and :math:`(Pm_k, PC_kP^T)`: the responsibilities are
normalised over all :math:`2K`, and a draw's share in a mirrored component enters :math:`m_k, C_k` as the mirrored
draw :math:`Pz_i` (EM for a mixture with tied parameters; :math:`P` a permutation, so
:math:`N(z; Pm, PCP^T) = N(Pz; m, C)`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import solve_triangular
from scipy.special import expit, log_expit, logit, logsumexp
from scipy.stats import chi2

from bayestissue._validation import ValidationError
from bayestissue.inference.diagnostics import import_arviz
from bayestissue.inference.ordering import folded, swapped
from bayestissue.inference.proposals import TMixture, fit_t_mixture

__all__ = [
    "ImportanceEvidence",
    "ImportanceOptions",
    "UnitProposal",
    "fit_unit_proposal",
    "importance_evidence",
    "pooled_unit_draws",
    "unit_logit",
]

#: Pareto k-hat above which the weights' variance is not trusted (Vehtari et al. 2024, section 3.2.4)
K_HAT_MAX = 0.7
#: the batches' log Z must agree with their own errors at this p-value (as nested runs', evidence.py)
P_MIN = 0.01


@dataclass(frozen=True)
class ImportanceOptions:
    """Settings of :func:`importance_evidence` (validated on construction).

    n_draws : proposal draws of the estimate (the likelihood calls it costs, besides the adaptation's).
    n_batches : independent batches the draws are split into, compared with their own errors (>= 2).
    adapt_rounds, adapt_draws : at most this many rounds of weighted EM on the proposal's own draws before the
        estimate (module docstring), and the draws of each.
    adapt_patience, adapt_tol : the adaptation stops early once its last ``adapt_patience`` rounds, each with Pareto
        :math:`\\hat k` below :data:`K_HAT_MAX`, have a median estimate of :math:`\\log Z` at most ``adapt_tol``
        nats above the median of the ``adapt_patience`` rounds before them (module docstring; ``adapt_patience`` 0:
        every round runs).
    n_components, widen, df : the Student-t mixture (:func:`~bayestissue.inference.proposals.fit_t_mixture`; the
        components are reduced so that each has 20 d draws at least). The defaults are those measured on the joint
        mirror model (analyses/evidence_check.py).
    defensive : the prior's share :math:`\\alpha` of the proposal.
    chunk : points per likelihood call (one batched forward solve) and per progress report.
    em_clip : in each adaptation round the ``em_clip`` largest weights are lowered to the ``em_clip``-th largest
        before the EM step (module docstring; 0: the weights as they are). The estimate's weights are never clipped.
    """

    n_draws: int = 100_000
    n_batches: int = 4
    adapt_rounds: int = 40
    adapt_draws: int = 40_000
    adapt_patience: int = 3
    adapt_tol: float = 0.1
    n_components: int = 48
    widen: float = 1.5
    df: float = 5.0
    defensive: float = 0.05
    chunk: int = 2000
    em_clip: int = 0

    def __post_init__(self):
        for name, low in (("n_draws", 100), ("n_batches", 2), ("adapt_rounds", 0), ("adapt_draws", 100),
                          ("adapt_patience", 0), ("n_components", 1), ("chunk", 1), ("em_clip", 0)):  # fmt: skip
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < low:
                raise ValidationError(name, v, f"an integer >= {low}")
        if self.n_draws < 50 * self.n_batches:
            raise ValidationError("n_draws", self.n_draws, f"at least 50 per batch ({50 * self.n_batches})")
        for name, ok, expected in (("widen", lambda v: 1.0 <= v <= 10.0, "a number in [1, 10]"),
                                   ("df", lambda v: v >= 1.0, "a number >= 1"),
                                   ("defensive", lambda v: 0.0 < v < 1.0, "a number in (0, 1)"),
                                   ("adapt_tol", lambda v: v > 0.0, "a number > 0")):  # fmt: skip
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, float | int) or not ok(v):
                raise ValidationError(name, v, expected)


@dataclass(frozen=True)
class UnitProposal:
    """The defensive proposal on the unit cube (module docstring): the prior with share ``defensive`` and
    ``mixture``, a :class:`~bayestissue.inference.proposals.TMixture` over :math:`z = \\operatorname{logit} u`,
    symmetrised over ``swap`` (two index groups whose exchange leaves the likelihood unchanged; module docstring)
    when given."""

    mixture: TMixture
    defensive: float
    swap: tuple[tuple[int, ...], tuple[int, ...]] | None = None

    @property
    def ndim(self) -> int:
        return self.mixture.ndim

    def sample_logit(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` draws as :math:`z = \\operatorname{logit} u` ``(n, d)`` (the prior's share drawn uniformly)."""
        from_prior = rng.random(n) < self.defensive
        z = np.empty((n, self.ndim))
        k = int(from_prior.sum())
        # logit(0) = -inf: the one value of rng.random (probability 2^-53 a coordinate) moved to the smallest float
        z[from_prior] = logit(np.maximum(rng.random((k, self.ndim)), np.finfo(float).tiny))
        z[~from_prior] = self.mixture.sample(n - k, np.random.RandomState(rng.integers(2**31 - 1)))
        if self.swap is not None:
            mirrored = ~from_prior & (rng.random(n) < 0.5)
            z[mirrored] = swapped(z[mirrored], self.swap)
        return z

    def logpdf_logit(self, z) -> np.ndarray:
        """:math:`\\log q(u)` at :math:`u = \\operatorname{expit} z` (a density on the unit cube, evaluated from
        :math:`z` for accuracy near the faces: :math:`\\log u(1 - u) = \\log\\sigma(z) + \\log\\sigma(-z)`)."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        log_jac = np.sum(log_expit(z) + log_expit(-z), axis=1)
        m = self.mixture.logpdf(z)
        if self.swap is not None:
            m = np.logaddexp(m, self.mixture.logpdf(swapped(z, self.swap))) - np.log(2.0)
        mix = np.log1p(-self.defensive) + m - log_jac
        return np.logaddexp(np.log(self.defensive), mix)


def unit_logit(unit) -> np.ndarray:
    """:math:`\\operatorname{logit}` of unit-cube points ``(n, d)``, moved 1e-12 inside the faces (where the logit
    is infinite)."""
    return logit(np.clip(np.atleast_2d(np.asarray(unit, dtype=float)), 1e-12, 1 - 1e-12))


def fit_unit_proposal(unit_draws, options: ImportanceOptions = ImportanceOptions(), *, weights=None, seed: int = 0,
                      rng=None, swap=None) -> UnitProposal:  # fmt: skip
    """The proposal fitted to draws in unit-cube coordinates ``(n, d)`` (equal weights, or ``weights`` summing to
    one: then resampled, systematically, to as many equal-weight draws as Kish's effective sample size allows, at
    most ``n``). Coordinates on a face of the cube are moved 1e-12 inside it. With ``swap`` (two index groups of
    equal length whose exchange leaves the likelihood unchanged) the draws are folded onto the copy
    :math:`u_{a_0} \\ge u_{b_0}` and the proposal is symmetrised (module docstring)."""
    u = np.asarray(unit_draws, dtype=float)
    if u.ndim != 2 or not np.all(np.isfinite(u)) or np.any((u < 0) | (u > 1)):
        raise ValidationError("unit draws", f"array of shape {u.shape}", "finite values in [0, 1] of shape (n, d)")
    if weights is not None:
        w = np.asarray(weights, dtype=float)
        n = int(min(u.shape[0], max(2 * (u.shape[1] + 1), 1.0 / np.sum(w**2))))
        gen = np.random.default_rng(rng if rng is not None else seed)
        idx = np.minimum(np.searchsorted(np.cumsum(w), (gen.random() + np.arange(n)) / n), w.size - 1)
        u = u[idx]
    if swap is not None:
        a, b = (tuple(int(i) for i in g) for g in swap)
        if len(a) != len(b) or not a or set(a) & set(b) or not set(a + b) <= set(range(u.shape[1])):
            raise ValidationError("swap", swap, f"two disjoint index groups of equal length in [0, {u.shape[1]})")
        swap = (a, b)
        u = folded(u, swap)
    z = unit_logit(u)
    mix = fit_t_mixture(z, n_components=options.n_components, widen=options.widen, df=options.df, seed=seed)
    return UnitProposal(mix, float(options.defensive), swap)


@dataclass
class ImportanceEvidence:
    """The estimate of :func:`importance_evidence`: ``log_z`` and its error (delta method over all draws), the
    batches' own, the Pareto :math:`\\hat k` of the weights, their Kish effective sample size, the likelihood calls
    (adaptation included; none for draws outside), the failed solves among them and the draws outside the target's
    support (zero likelihood by construction, not failures; ``outside`` of :func:`importance_evidence`), the
    seconds, each adaptation round's :math:`\\log\\hat Z` and Pareto :math:`\\hat k`, whether the adaptation met
    its stopping rule (:class:`ImportanceOptions`) before its last round, and the weighted draws (``unit``
    coordinates, ``log_w`` normalised) for the posterior's quantiles."""

    log_z: float
    log_z_err: float
    batch_log_z: np.ndarray
    batch_err: np.ndarray
    k_hat: float
    ess: float
    n_draws: int
    n_calls: int
    n_failed: int
    n_outside: int
    time_s: float
    adapt_log_z: list[float]
    adapt_k_hat: list[float]
    adapt_converged: bool
    unit: np.ndarray = field(repr=False)
    log_w: np.ndarray = field(repr=False)

    @property
    def batch_p(self) -> float:
        """p-value of the batches' :math:`\\log\\hat Z` scatter against their own errors (:math:`\\chi^2`, B - 1 df)."""
        v, e = self.batch_log_z, self.batch_err
        mean = np.sum(v / e**2) / np.sum(1 / e**2)
        return float(chi2.sf(np.sum((v - mean) ** 2 / e**2), v.size - 1))

    @property
    def trusted(self) -> bool:
        """:math:`\\hat k <` :data:`K_HAT_MAX` and the batches agree (p >= :data:`P_MIN`)."""
        return bool(self.k_hat < K_HAT_MAX and self.batch_p >= P_MIN)

    def verdict(self) -> str:
        """One line: TRUSTED, or NOT TRUSTED with the reasons."""
        why = []
        if not self.k_hat < K_HAT_MAX:
            why.append(f"Pareto k-hat {self.k_hat:.2f} >= {K_HAT_MAX} (the weights' variance not finite in practice)")
        if not self.batch_p >= P_MIN:
            runs = ", ".join(f"{v:.2f}" for v in self.batch_log_z)
            why.append(f"batches disagree beyond their own errors (log Z {runs}, p = {self.batch_p:.2g} < {P_MIN})")
        rounds = len(self.adapt_log_z)
        adapted = f"{rounds} adaptation rounds" + ("" if self.adapt_converged or rounds == 0 else ", not converged")
        head = (f"log Z {self.log_z:.3f} +- {self.log_z_err:.3f} by importance sampling ({adapted}; {self.n_draws} "
                f"draws, ESS {self.ess:.0f}, k-hat {self.k_hat:.2f}, batches p = {self.batch_p:.2g})")  # fmt: skip
        return head + (": TRUSTED" if not why else ": NOT TRUSTED: " + "; ".join(why))


def _weighted_em(mixture: TMixture, z: np.ndarray, w: np.ndarray, widen: float, swap=None) -> TMixture:
    """One adaptation round (module docstring): weighted EM of the mixture's Gaussian moments (its scales over
    ``widen**2``) on draws ``z`` ``(n, d)`` with normalised weights ``w``, blended with the old moments by each
    component's effective number of draws, then widened again. With ``swap`` the tied EM of the symmetrised
    mixture: the draws and their mirror images, responsibilities normalised over each pair's :math:`2K`."""
    n, d = z.shape
    if swap is not None:
        z, w = np.concatenate([z, swapped(z, swap)]), np.concatenate([w, w])
    covs = mixture.covs / widen**2
    log_r = np.empty((len(mixture.weights), z.shape[0]))
    for k, (pk, m, c) in enumerate(zip(mixture.weights, mixture.means, covs, strict=True)):
        chol = np.linalg.cholesky(c)
        r = solve_triangular(chol, (z - m).T, lower=True)
        log_r[k] = np.log(pk) - np.log(np.diagonal(chol)).sum() - 0.5 * np.sum(r * r, axis=0)
    norm = (
        logsumexp(log_r, axis=0)
        if swap is None
        else np.tile(logsumexp(np.vstack([log_r[:, :n], log_r[:, n:]]), axis=0), 2)
    )
    a = np.exp(log_r - norm) * w  # (K, n or 2n): weight times responsibility
    mass = a.sum(axis=1)
    # a component with (almost) none of the weight keeps its moments: n_k = 1 / sum((a / mass)^2), which for a mass
    # near the smallest floats is 0 / 0 if written mass^2 / sum(a^2)
    informed = mass > 1e-12
    safe = np.where(informed, mass, 1.0)
    n_k = np.zeros(mass.size)
    n_k[informed] = 1.0 / np.sum((a[informed] / mass[informed, None]) ** 2, axis=1)
    lam = n_k / (n_k + d + 2.0)
    means_new = (a @ z) / safe[:, None]
    means = lam[:, None] * means_new + (1 - lam[:, None]) * mixture.means
    dev = z[None, :, :] - means[:, None, :]
    covs_new = np.einsum("kn,kni,knj->kij", a, dev, dev) / safe[:, None, None]
    scale = np.mean(np.diagonal(covs, axis1=1, axis2=2))
    covs = lam[:, None, None] * covs_new + (1 - lam[:, None, None]) * covs + 1e-10 * scale * np.eye(d)
    weights = np.maximum(mass, 1e-3 / mass.size)
    return TMixture(weights / weights.sum(), means, covs * widen**2, mixture.df)


def _clipped(log_w: np.ndarray, m: int) -> np.ndarray:
    """Normalised weights with the ``m`` largest lowered to the ``m``-th largest (none when ``m`` is 0 or not less
    than the finite weights' number): the nonlinear transformation of Koblents & Miguez (2015, module docstring)."""
    finite = log_w[np.isfinite(log_w)]
    if 0 < m < finite.size:
        log_w = np.minimum(log_w, np.partition(finite, finite.size - m)[finite.size - m])
    return np.exp(log_w - logsumexp(log_w))


def _log_weights(log_l_unit, proposal, n, rng, chunk, progress, stage, outside=None):
    """``n`` proposal draws (logit coordinates), their log-weights :math:`\\log L - \\log q`, the failed solves and
    the draws ``outside`` the target's support (a predicate on unit points, or None). A non-finite log-likelihood
    has weight 0; it is a failed solve unless the draw is outside."""
    z = proposal.sample_logit(n, rng)
    log_w = np.empty(n)
    failed = off = 0
    for start in range(0, n, chunk):
        zs = z[start : start + chunk]
        us = expit(zs)
        ll = np.asarray(log_l_unit(us), dtype=float)
        out = np.zeros(ll.size, dtype=bool) if outside is None else np.asarray(outside(us), dtype=bool)
        bad = ~np.isfinite(ll)
        failed, off = failed + int(np.sum(bad & ~out)), off + int(out.sum())
        log_w[start : start + chunk] = np.where(bad, -np.inf, ll) - proposal.logpdf_logit(zs)
        if progress is not None:
            progress(stage, min(start + chunk, n), n)
    return z, log_w, failed, off


def _log_mean(log_w) -> tuple[float, float]:
    """:math:`\\log \\bar w` and its delta-method error :math:`s_w / (\\sqrt N \\bar w)`."""
    n = log_w.size
    log_mean = float(logsumexp(log_w) - np.log(n))
    rel = np.exp(log_w - log_mean)  # w / mean(w)
    return log_mean, float(np.sqrt(np.var(rel, ddof=1) / n))


def _pareto_k(log_w) -> float:
    """Pareto :math:`\\hat k` of the finite weights' upper tail (arviz's ``psislw``, Vehtari et al. 2024)."""
    finite = log_w[np.isfinite(log_w)]
    # psislw's generalised-Pareto fit overflows exp() for candidate shapes far from the tail's: those get weight 0,
    # which is the limit it computes, so the warning is silenced, not the result changed
    with np.errstate(over="ignore"):
        _, k_hat = import_arviz().psislw(finite - finite.max())
    return float(k_hat)


def _adapted(log_z: list[float], k_hat: list[float], options: ImportanceOptions) -> bool:
    """The adaptation's stopping rule (:class:`ImportanceOptions`, module docstring): the last ``p =
    adapt_patience`` rounds have :math:`\\hat k <` :data:`K_HAT_MAX` and a median estimate at most ``adapt_tol``
    above the median of the ``p`` rounds before them. A round's estimate from a poor proposal is typically low (its
    weights' mass sits in a tail its draws rarely reach), so a rising median says the proposal is still improving;
    the medians keep one round that landed high (by a large weight, or by chance) from ending the rounds early or
    from setting a bar the next rounds cannot meet."""
    p = options.adapt_patience
    if p == 0 or len(log_z) < 2 * p or not all(k < K_HAT_MAX for k in k_hat[-p:]):
        return False
    return bool(np.median(log_z[-p:]) <= np.median(log_z[-2 * p : -p]) + options.adapt_tol)


def importance_evidence(
    log_l_unit: Callable[[np.ndarray], np.ndarray],
    proposal: UnitProposal,
    options: ImportanceOptions = ImportanceOptions(),
    *,
    rng=None,
    progress: Callable | None = None,
    outside: Callable[[np.ndarray], np.ndarray] | None = None,
) -> ImportanceEvidence:
    """:math:`\\log Z` of ``log_l_unit`` (the log-likelihood of unit-cube points ``(n, d)``, batched) by importance
    sampling from ``proposal`` after at most ``options.adapt_rounds`` refits (module docstring). ``progress(stage, done,
    total)`` after every chunk, ``stage`` ``"adapt 1"``, ... or ``"estimate"``. ``outside(unit)``: which unit points
    lie outside the target's support, where ``log_l_unit`` is :math:`-\\infty` by construction (e.g. one labelling
    of exchangeable parameters): their zero weights are counted apart from failed solves."""
    rng = np.random.default_rng(rng)
    t0 = time.perf_counter()
    calls = failed = off = 0
    adapt_log_z, adapt_k_hat = [], []
    converged = False
    for r in range(options.adapt_rounds):
        z, log_w, f, o = _log_weights(log_l_unit, proposal, options.adapt_draws, rng, options.chunk, progress,
                                      f"adapt {r + 1}", outside)  # fmt: skip
        calls, failed, off = calls + z.shape[0] - o, failed + f, off + o
        if not np.any(np.isfinite(log_w)):
            raise ValidationError("importance proposal", "every draw failed or has zero likelihood",
                                  "a proposal that reaches the posterior")  # fmt: skip
        adapt_log_z.append(_log_mean(log_w)[0])
        adapt_k_hat.append(_pareto_k(log_w))
        mixture = _weighted_em(proposal.mixture, z, _clipped(log_w, options.em_clip), options.widen, proposal.swap)
        proposal = UnitProposal(mixture, proposal.defensive, proposal.swap)
        if _adapted(adapt_log_z, adapt_k_hat, options):
            converged = True
            break
    z, log_w, f, o = _log_weights(
        log_l_unit, proposal, options.n_draws, rng, options.chunk, progress, "estimate", outside
    )
    calls, failed, off = calls + z.shape[0] - o, failed + f, off + o
    log_z, err = _log_mean(log_w)
    batches = np.array_split(np.arange(options.n_draws), options.n_batches)
    b = np.array([_log_mean(log_w[i]) for i in batches])
    log_w_norm = log_w - logsumexp(log_w)
    return ImportanceEvidence(
        log_z=log_z,
        log_z_err=err,
        batch_log_z=b[:, 0],
        batch_err=b[:, 1],
        k_hat=_pareto_k(log_w),
        ess=float(1.0 / np.sum(np.exp(2 * log_w_norm))),
        n_draws=int(options.n_draws),
        n_calls=int(calls),
        n_failed=int(failed),
        n_outside=int(off),
        time_s=time.perf_counter() - t0,
        adapt_log_z=adapt_log_z,
        adapt_k_hat=adapt_k_hat,
        adapt_converged=converged,
        unit=expit(z),
        log_w=log_w_norm,
    )


def pooled_unit_draws(problem, points, weights) -> tuple[np.ndarray, np.ndarray]:
    """The weighted points of one or more nested runs of ``problem`` (``points[r]`` ``(n_r, >= n_material)``, its
    parameter sets, ``weights[r]`` their weights summing to one; a
    :class:`~bayestissue.inference.sampling.NestedSample`'s runs), pooled (each run weighing ``1/n_runs``), as
    unit-cube coordinates of the sampled material parameters (what
    :func:`~bayestissue.inference.sampling.nested.nested_target` samples with the noise sds integrated out) and their
    weights, summing to one. With exchangeable parameter groups each point comes twice, once with the groups
    swapped: the runs sample the whole box, where the likelihood holds both labellings, and so must the proposal."""
    n_mat = problem.n_material
    u = problem.material.to_unit(np.concatenate([np.asarray(x)[:, :n_mat] for x in points]))
    w = np.concatenate([np.asarray(x) / len(weights) for x in weights])
    if problem.exchangeable is not None:
        u, w = np.concatenate([u, swapped(u, problem.exchangeable)]), np.concatenate([w, w]) / 2.0
    return np.clip(u, 0.0, 1.0), w / w.sum()
