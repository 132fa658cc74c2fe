r"""A population of specimens: the two-stage hierarchical model over per-specimen posteriors.

Labs test several specimens per group and ask how the groups differ and what a new specimen will look like. Each
specimen :math:`i` (group :math:`g(i)`) has its own parameters; on each population parameter's scale :math:`z`
(:math:`z = \ln\theta` for a parameter whose box is positive, :math:`z = \theta` otherwise)

.. math:: z_{ij} = m_j + d_{g(i),j} + s_j \varepsilon_{ij}, \qquad \varepsilon_{ij} \sim N(0, 1),
          \qquad d_{\mathrm{ref},j} = 0,

with weakly informative priors scaled by the width :math:`w_j` of parameter :math:`j`'s box on that scale:
:math:`m_j \sim N(c_j, w_j^2)` (:math:`c_j` the box's centre), :math:`d_{gj} \sim N(0, (w_j/4)^2)` and
:math:`s_j \sim \text{half-normal}(w_j/4)` (Gelman 2006, doi:10.1214/06-BA117A; both scales can be set). On the log
scale :math:`d` is a log ratio (``exp(d)``: the factor between a group's and the reference group's typical specimen)
and :math:`s` about the coefficient of variation between specimens.

**Two stages** (Lunn, Barrett, Sweeting & Thompson 2013, doi:10.1111/rssc.12007; Goudie et al. 2019 Markov
melding, doi:10.1214/18-BA1104): stage 1 fits each specimen alone under the box prior :math:`\pi_0` (any engine, in
parallel); stage 2 samples the population by Metropolis-within-Gibbs, with each specimen's own posterior draws as
the proposal for its parameters. The acceptance ratio of a proposed draw :math:`z'` against the current :math:`z`,

.. math:: \min\Bigl(1, \frac{N(z' \mid m + d_{g}, s)\,/\,\pi_0(z')}{N(z \mid m + d_{g}, s)\,/\,\pi_0(z)}\Bigr),

replaces the broad stage-1 prior by the population density, so the specimen's likelihood never has to be evaluated
again: stage 2 costs no forward solves. :math:`\pi_0(z) = \pi_0(\theta)\,|d\theta/dz|` (for a log-uniform prior on
the log scale a constant). Given the specimens' :math:`z`, :math:`(m_j, d_{\cdot j})` is a Gaussian linear
regression with a Gaussian prior (drawn exactly) and :math:`\ln s_j` is drawn by slice sampling (Neal 2003,
doi:10.1214/aos/1056562461).

What the two stages assume: the stage-1 prior factorises over the population parameters and the others (box
priors do; an ordering of Prony branches or Ogden terms does if all of a group's keys are population parameters
or none are, which :func:`check_population_parameters` enforces), and the population density is, in effect,
truncated to the box (stage 1 has no draws outside it): choose boxes wider than the population. A specimen's
posterior that is much wider than the population makes its proposals rarely accepted: the acceptance rate per
specimen is reported; stage-1 draws must be many enough (thousands) to cover the narrower population conditional.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError

__all__ = [
    "HierarchyPosterior",
    "PopulationScale",
    "check_population_parameters",
    "population_scale",
    "sample_population",
]


@dataclass(frozen=True)
class PopulationScale:
    """Per population parameter: ``log`` (positive box) or not, the box on the population scale, and the log stage-1
    prior density at ``z`` (``log_prior0``, up to a constant)."""

    names: tuple[str, ...]
    log: np.ndarray  # (p,) bool
    lower: np.ndarray  # (p,) on the population scale
    upper: np.ndarray
    priors: tuple  # the stage-1 box priors (objects with logpdf in natural units)

    def to_z(self, theta) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        return np.where(self.log, np.log(np.where(self.log, theta, 1.0)), theta)

    def to_theta(self, z) -> np.ndarray:
        z = np.asarray(z, dtype=float)
        return np.where(self.log, np.exp(np.where(self.log, z, 0.0)), z)

    def log_prior0(self, z) -> np.ndarray:
        """log pi_0(z) summed over the parameters (last axis): the box prior in natural units plus log |dtheta/dz|."""
        z = np.asarray(z, dtype=float)
        theta = self.to_theta(z)
        out = np.zeros(z.shape[:-1])
        for j, prior in enumerate(self.priors):
            out += prior.logpdf(theta[..., j]) + (z[..., j] if self.log[j] else 0.0)
        return out

    @property
    def width(self) -> np.ndarray:
        return self.upper - self.lower

    @property
    def centre(self) -> np.ndarray:
        return 0.5 * (self.upper + self.lower)


def population_scale(specs: Sequence) -> PopulationScale:
    """The population scale of each :class:`~bayestissue.inference.parameters.ParameterSpec` (log if its box is
    positive)."""
    log = np.array([s.lower > 0.0 for s in specs])
    lo = np.array([np.log(s.lower) if lg else s.lower for s, lg in zip(specs, log, strict=True)])
    hi = np.array([np.log(s.upper) if lg else s.upper for s, lg in zip(specs, log, strict=True)])
    return PopulationScale(tuple(s.name for s in specs), log, lo, hi, tuple(s.prior_dist for s in specs))


def check_population_parameters(names: Sequence[str], sampled: Sequence[str], ordered=(), *, field="parameters"):
    """Refuse population parameters that are not sampled (fixed, tied or unknown) or that split an ordered group
    (some of its keys population parameters, some not: the stage-1 prior would not factorise)."""
    import difflib

    if not names:
        raise ValidationError(field, list(names), "at least one sampled parameter name")
    for n in names:
        if n not in sampled:
            near = difflib.get_close_matches(n, list(sampled), n=1, cutoff=0.6)
            hint = f"did you mean {near[0]!r}? " if near else ""
            raise ValidationError(field, n, "a sampled parameter of the specimens' model",
                                  f"{hint}sampled: {', '.join(sampled)}")  # fmt: skip
    if len(set(names)) != len(names):
        raise ValidationError(field, list(names), "distinct names")
    for g in ordered:
        inside = [k for k in g.keys if k in names]
        if inside and len(inside) != len(g.keys):
            raise ValidationError(field, list(names), f"all or none of the ordered keys {g.text}",
                                  "the stage-1 prior orders them: a part of the group does not factorise")  # fmt: skip


@dataclass
class HierarchyPosterior:
    """Stage-2 draws, chains first: ``m`` (C, n, p), ``d`` (C, n, G - 1, p) the effects of the non-reference groups,
    ``s`` (C, n, p), ``z`` (C, n, I, p) each specimen's parameters; ``acceptance`` (I,) each specimen's acceptance
    rate of its stage-1 proposals; all on the population scale. ``sd_prior`` and ``effect_prior`` (p,): the
    half-normal scale of s and the sd of d used (the prior of m is N(box centre, box width^2))."""

    scale: PopulationScale
    groups: tuple[str, ...]  # reference first
    specimens: tuple[str, ...]
    specimen_group: np.ndarray  # (I,) index into groups
    m: np.ndarray
    d: np.ndarray
    s: np.ndarray
    z: np.ndarray
    acceptance: np.ndarray
    sd_prior: np.ndarray
    effect_prior: np.ndarray

    def flat(self, name: str) -> np.ndarray:
        a = getattr(self, name)
        return a.reshape((a.shape[0] * a.shape[1], *a.shape[2:]))

    def group_mean(self, g: int) -> np.ndarray:
        """(C * n, p): the population-scale mean of group ``g``'s specimens, m + d_g."""
        m = self.flat("m")
        return m if g == 0 else m + self.flat("d")[:, g - 1]

    def new_specimen(self, g: int, rng=None) -> np.ndarray:
        """(C * n, p): one new specimen of group ``g`` per draw, z = m + d_g + s eps (the predictive distribution)."""
        rng = np.random.default_rng(rng)
        mean = self.group_mean(g)
        return mean + self.flat("s") * rng.standard_normal(mean.shape)

    def n_in_group(self, g: int) -> int:
        return int(np.count_nonzero(self.specimen_group == g))

    def prior_text(self) -> str:
        """The population priors used, per parameter on its population scale."""
        sc = self.scale
        return "; ".join(
            f"{n} ({'ln' if lg else 'linear'}): m ~ N({c:.3g}, {w:.3g}^2), d ~ N(0, {e:.3g}^2), "
            f"s ~ half-normal({v:.3g})"
            for n, lg, c, w, e, v in zip(sc.names, sc.log, sc.centre, sc.width, self.effect_prior, self.sd_prior,
                                         strict=True)
        )  # fmt: skip


def _slice_log_s(u, logf, rng, width=1.0, max_steps=50):
    """One slice-sampling update (stepping out, shrinkage) of the scalar ``u`` under log density ``logf``."""
    y = logf(u) + np.log(rng.random())
    left = u - width * rng.random()
    right = left + width
    for _ in range(max_steps):
        if logf(left) < y:
            break
        left -= width
    for _ in range(max_steps):
        if logf(right) < y:
            break
        right += width
    while True:
        new = left + (right - left) * rng.random()
        if logf(new) >= y:
            return new
        if new < u:
            left = new
        else:
            right = new


def sample_population(
    stage1: Sequence[np.ndarray],
    specs: Sequence,
    specimen_groups: Sequence[str],
    *,
    reference: str | None = None,
    specimens: Sequence[str] | None = None,
    sd_scale: dict | None = None,
    effect_scale: dict | None = None,
    n_chains: int = 4,
    n_warmup: int = 1000,
    n_draws: int = 2000,
    n_proposals: int = 5,
    seed: int = 0,
) -> HierarchyPosterior:
    """Stage 2 (module docstring).

    Parameters
    ----------
    stage1 : per specimen, (n_i, p) posterior draws of the population parameters in natural units, under the box
        priors of ``specs`` (the same p parameters, in order).
    specimen_groups : each specimen's group name; ``reference`` (default: the first specimen's group) has d = 0.
    sd_scale, effect_scale : name -> the half-normal scale of s_j and the sd of d_gj on the population scale
        (default: a quarter of the box's width there).
    n_proposals : independence proposals per specimen per sweep.
    """
    scale = population_scale(specs)
    p = len(scale.names)
    zs = []
    for i, draws in enumerate(stage1):
        draws = np.asarray(draws, dtype=float)
        if draws.ndim != 2 or draws.shape[1] != p or draws.shape[0] < 10 or not np.all(np.isfinite(draws)):
            raise ValidationError(f"stage-1 draws of specimen {i + 1}", getattr(draws, "shape", draws),
                                  f"a finite (n >= 10, {p}) array")  # fmt: skip
        zs.append(scale.to_z(draws))
    n_spec = len(zs)
    specimen_groups = [str(g) for g in specimen_groups]
    if len(specimen_groups) != n_spec:
        raise ValidationError("specimen groups", specimen_groups, f"one group per specimen ({n_spec})")
    reference = specimen_groups[0] if reference is None else reference
    if reference not in specimen_groups:
        raise ValidationError(
            "reference group", reference, f"one of the specimens' groups {sorted(set(specimen_groups))}"
        )
    groups = (reference, *sorted(set(specimen_groups) - {reference}))
    gidx = np.array([groups.index(g) for g in specimen_groups])
    n_groups = len(groups)
    sd0 = np.array([(sd_scale or {}).get(n, w / 4.0) for n, w in zip(scale.names, scale.width, strict=True)])
    eff0 = np.array([(effect_scale or {}).get(n, w / 4.0) for n, w in zip(scale.names, scale.width, strict=True)])
    if not (np.all(sd0 > 0) and np.all(eff0 > 0)):
        raise ValidationError("population prior scales", {"sd": sd0.tolist(), "effect": eff0.tolist()}, "positive")
    lp0 = [scale.log_prior0(z) for z in zs]
    # design: intercept + one indicator per non-reference group
    X = np.zeros((n_spec, n_groups))
    X[:, 0] = 1.0
    for i, g in enumerate(gidx):
        if g > 0:
            X[i, g] = 1.0
    sizes = np.array([z.shape[0] for z in zs])
    rng_root = np.random.SeedSequence(seed)
    n_total = n_warmup + n_draws
    out_m = np.empty((n_chains, n_draws, p))
    out_d = np.empty((n_chains, n_draws, n_groups - 1, p))
    out_s = np.empty((n_chains, n_draws, p))
    out_z = np.empty((n_chains, n_draws, n_spec, p))
    accepted = np.zeros(n_spec)
    for c, ss in enumerate(rng_root.spawn(n_chains)):
        rng = np.random.default_rng(ss)
        k = np.array([rng.integers(z.shape[0]) for z in zs])
        z = np.stack([zs[i][k[i]] for i in range(n_spec)])
        s = sd0 / 2.0
        beta = np.zeros((n_groups, p))
        beta[0] = z.mean(axis=0)
        for t in range(n_total):
            mu = X @ beta  # (I, p)
            # specimens: independence proposals from each specimen's stage-1 draws
            for _ in range(n_proposals):
                kk = (rng.random(n_spec) * sizes).astype(np.int64)
                zn = np.stack([zs[i][kk[i]] for i in range(n_spec)])
                lp_new = np.array([lp0[i][kk[i]] for i in range(n_spec)])
                lp_old = np.array([lp0[i][k[i]] for i in range(n_spec)])
                log_r = -0.5 * (np.sum(((zn - mu) / s) ** 2, axis=1) - np.sum(((z - mu) / s) ** 2, axis=1))
                log_r += lp_old - lp_new
                take = np.log(rng.random(n_spec)) < log_r
                k[take], z[take] = kk[take], zn[take]
                if t >= n_warmup:
                    accepted += take
            # (m, d) per parameter: conjugate Gaussian regression
            for j in range(p):
                prec0 = np.r_[1.0 / scale.width[j] ** 2, np.full(n_groups - 1, 1.0 / eff0[j] ** 2)]
                mean0 = np.r_[scale.centre[j], np.zeros(n_groups - 1)]
                A = X.T @ X / s[j] ** 2 + np.diag(prec0)
                b = X.T @ z[:, j] / s[j] ** 2 + prec0 * mean0
                L = np.linalg.cholesky(A)
                mean = np.linalg.solve(A, b)
                beta[:, j] = mean + np.linalg.solve(L.T, rng.standard_normal(n_groups))
            mu = X @ beta
            # population sds: slice sampling of log s_j (half-normal prior, Jacobian of s = e^u)
            for j in range(p):
                rss = float(np.sum((z[:, j] - mu[:, j]) ** 2))

                def logf(u, rss=rss, j=j):
                    return -n_spec * u - 0.5 * rss * np.exp(-2.0 * u) - 0.5 * np.exp(2.0 * u) / sd0[j] ** 2 + u

                s[j] = np.exp(_slice_log_s(np.log(s[j]), logf, rng))
            if t >= n_warmup:
                r = t - n_warmup
                out_m[c, r], out_d[c, r], out_s[c, r], out_z[c, r] = beta[0], beta[1:], s, z
    acceptance = accepted / (n_chains * n_draws * n_proposals)
    names = tuple(specimens) if specimens is not None else tuple(f"specimen_{i + 1}" for i in range(n_spec))
    return HierarchyPosterior(scale, groups, names, gidx, out_m, out_d, out_s, out_z, acceptance, sd0, eff0)
