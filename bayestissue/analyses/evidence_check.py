r"""The evidence of the study's models a second way: importance sampling from a proposal fitted to a nested run
(issue 36).

The model-choice stage (:mod:`~bayestissue.analyses.model_choice`) estimates each model's evidence by 4 UltraNest runs;
where the posterior has a flat ridge the runs disagree beyond their own errors (the joint mirror model: log Z
911.4-917.2 over eight runs, T2's full model 322.5-325.6) and no factor can be read from them. This stage estimates the
same evidence by importance sampling (:mod:`~bayestissue.inference.sampling.importance`): one cheap nautilus run of the
same problem (:data:`CHECK_SETTINGS`: 500 live points, one network trained to 1e-4, 10 000 effective draws) supplies the
draws a Student-t mixture is fitted to, up to 40 rounds of weighted EM adapt it (until the rounds' estimates stop
rising), and 100 000 fresh draws give

.. math:: \ln\hat Z = \ln \frac1N \sum_i \frac{L(u_i)}{q(u_i)}, \qquad
   \ln B_{ab} = \ln\hat Z_a - \ln\hat Z_b, \quad \sigma_{\ln B} = \sqrt{\sigma_a^2 + \sigma_b^2},

each :math:`\sigma^2` the delta-method variance of the importance-sampling mean plus :data:`PROPOSAL_ERROR` squared:
the spread between estimates of one evidence from two independent proposals, measured larger than the delta-method
errors say (T1 mirror 992.116 +- 0.067 and 991.866 +- 0.039, the second from a nautilus run of 300 live points;
joint mirror 915.177 +- 0.046 and 915.506 +- 0.015, the second from one of 1 000). An estimate counts (``trusted``)
when the
Pareto :math:`\hat k` of its weights is below 0.7 and its 4 batches agree with their own errors; a factor between two
trusted estimates decides by :func:`~bayestissue.analyses.verdicts.evidence_decides`'s grades. The nautilus run's own
log Z is kept beside it (:attr:`EvidenceCheck.proposal_log_z`), the model-choice record's runs are compared in the
report.

What this estimate cannot see is posterior mass in a region that neither the nautilus run nor the adaptation reached
(the proposal then has no draws there; :mod:`~bayestissue.inference.sampling.importance`). Against that, its value
is checked against the nested runs of the model-choice record: a run far above it would point to such a region.
One such region is known in advance: the full model samples fibre families 2 and 3 over the whole box, and their
exchange leaves the likelihood unchanged (the fibre directions are mirror images about the loading axis), so its
posterior has two mirror copies of equal mass, of which a nautilus run may find one (the joint data set's: 99.99 %
of its weight at ginf2 > ginf3). The proposal is then symmetrised over that exchange (:func:`mirror_swap`, checked
on the run's draws before it is used).

Where a posterior is a sheet far thinner across one parameter than along it (the joint full model across kappa;
T1's full model across the softer fibre family's beta), the check integrates that parameter out per draw by
quadrature and samples the others (:data:`COLLAPSED`, :mod:`~bayestissue.inference.sampling.collapsed`). Where that
parameter belongs to one of the mirror families, which family is the softer depends on the labelling, so the check
is restricted to one labelling (family 2 not softer than family 3, by ginf; the nautilus draws folded onto it), where
the evidence is half the whole box's (the likelihood and the prior are symmetric under the exchange). The verdict
then also says how many draws' quadratures were doubtful and how much weight they hold (trusted only below
:data:`DOUBT_MAX`).

Each check also says how its evidence moves when every log-scaled box of the material parameters is narrowed or
widened by a factor 10 at each end (:func:`~bayestissue.analyses.box_width.box_shift_weighted`, from the estimate's
weighted draws; a collapsed check's from its quantile draws, each with the integrated parameter drawn from its
conditional), so that a factor's sensitivity to its boxes is known where the nested runs cannot give it. The noise
sds are left out: integrated out over boxes a factor's two models share, their terms cancel in the factor as long as
their posteriors lie inside the narrowed boxes (the nested runs' shares in the outermost decades: at most 2e-9).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.analyses.box_width import BoxShift, box_shift_weighted
from bayestissue.analyses.check_proposal import ProposalRun, proposal_run
from bayestissue.analyses.model_choice import (
    CANDIDATES,
    DATASETS,
    FACTORS,
    data_files,
    model_problem,
    numbers_hash,
)
from bayestissue.analyses.verdicts import evidence_decides, evidence_strength
from bayestissue.inference import NestedOptions
from bayestissue.inference.evidence import LEVELS, weighted_quantile
from bayestissue.inference.ordering import folded, swapped
from bayestissue.inference.sampling.collapsed import fit_line
from bayestissue.inference.sampling.importance import (
    ImportanceOptions,
    fit_unit_proposal,
    importance_evidence,
    pooled_unit_draws,
    unit_logit,
)
from bayestissue.inference.sampling.nested import nested_target
from bayestissue.io.records import RecordError, read_record, write_record
from bayestissue.paper import MIRROR_TIES

__all__ = [
    "CHECK_SEED",
    "COLLAPSED",
    "Collapse",
    "COLLAPSED_SETTINGS",
    "DOUBT_MAX",
    "PROPOSAL_ERROR",
    "CHECK_SETTINGS",
    "CheckCase",
    "DataProblems",
    "EvidenceCheck",
    "EvidenceCheckRecord",
    "Quadrature",
    "ProposalRun",
    "cached_check",
    "check_hash",
    "check_model",
    "check_task",
    "mirror_swap",
    "proposal_hash",
    "proposal_run",
]

#: Error (nats) added in quadrature to each importance-sampling log Z in a factor: the largest difference measured
#: between two independent proposals' estimates of one evidence (module docstring; 0.25 on T1 mirror, 0.33 on the
#: joint mirror model), which the delta-method errors (0.015-0.067) did not cover.
PROPOSAL_ERROR = 0.35
#: The stage's seed: data set ``j`` of :data:`~bayestissue.analyses.model_choice.DATASETS`, model ``k`` (its place
#: in the data set's candidates) uses ``CHECK_SEED + 10 j + k``.
CHECK_SEED = 20261206
#: Per mode the nautilus run that supplies the proposal's draws (:class:`~bayestissue.inference.NestedOptions`) and
#: the importance sampling (:class:`~bayestissue.inference.sampling.importance.ImportanceOptions`). Measured
#: (2026-12-06): on the joint mirror model a nautilus run of 1 000 live points took 136 100 calls and 360 s to 2 000
#: effective draws, 23 000 more to 20 000; a mixture fitted to those draws alone gave Pareto k-hat 0.78-0.89 at 16-100
#: components (the largest weights where gamma2 nears its bound), after 8 rounds of adaptation 0.40 (ESS 4 048 of
#: 60 000). On T1's mirror model the run of 1 000 live points took 549 700 calls and 894 s; from a run of 300 the
#: adapted proposal gave k-hat 0.62 and log Z 991.87 +- 0.04 (the 1 000-point run's own: 991.82), so the stage's
#: runs have 500. Eight rounds were not enough on the joint scale model (the rounds' estimates still rising,
#: final k-hat 2.21); the rounds now run until they stop rising (at most 40,
#: :class:`~bayestissue.inference.sampling.importance.ImportanceOptions`): measured on the stage's nautilus draws,
#: joint mirror 915.558 +- 0.010 (k-hat 0.51), scale 918.863 +- 0.030 (0.32), full 907.09 +- 0.12 NOT TRUSTED
#: (k-hat 1.22 after 40 rounds). The full model's proposal then missed the mirror copy of its posterior (the
#: nautilus run's weight 99.99 % at ginf2 > ginf3); symmetrised (:func:`mirror_swap`) the same draws gave 907.96 +-
#: 0.23, still NOT TRUSTED (k-hat 1.46; a tail of 2 or a 2.5-fold widening instead of 1.5 did no better: k-hat 1.60,
#: 4.81). Weights clipped in the EM rounds (``em_clip``, stop 73) kept its k-hat at 0.63-0.90, not below 0.7 to
#: stay, changed little on T1's mirror model and kept T2's full model from converging, so they are off
#: (:mod:`~bayestissue.inference.sampling.importance`, docs/verification.md). Each nautilus run's draws are
#: cached under :func:`proposal_hash` (a change of the importance sampler alone reruns only the importance sampling).
#: ``--quick`` is a capped smoke run (its numbers mean nothing).
CHECK_SETTINGS = {
    "quick": {
        "proposal": {"n_live": 100, "n_eff": 200, "n_runs": 1, "n_networks": 1, "max_evaluations": 4000},
        "importance": {"n_draws": 2000, "adapt_rounds": 1, "adapt_draws": 1000, "n_components": 4},
    },
    "full": {
        "proposal": {"n_live": 500, "n_eff": 10000, "n_runs": 1, "n_networks": 1, "network_tol": 1e-4},
        "importance": {"n_draws": 100_000, "adapt_rounds": 40, "adapt_draws": 40_000, "n_components": 48},
    },
}


@dataclass(frozen=True)
class Collapse:
    """How a check integrates ``param`` out (:mod:`~bayestissue.inference.sampling.collapsed`): ``zoom`` finer grids,
    and ``one_labelling``: only family 2's ginf not below family 3's, so that ``param`` is the softer family's."""

    param: str
    zoom: int = 0
    one_labelling: bool = False


#: The checks whose likelihood has one parameter integrated out by quadrature before importance sampling
#: (:mod:`~bayestissue.inference.sampling.collapsed`), by (data set, model): the parameter. The joint full model's
#: posterior is a curved sheet about 2e-4 thick in logit units, mostly across kappa (Hessian at its heaviest draws:
#: largest eigenvalue 2.1-2.5e7, the next 0.6-1.4e5); 48 components over all 11 parameters left k-hat at 0.98
#: (907.63 +- 0.10), and over the other 10 with kappa integrated out the first trial (10 rounds of 5 000, 20 000
#: draws, 4.97 M calls, 1 210 s beside two other runs) gave 907.89 +- 0.10 with k-hat 0.75; the stage's run, the
#: line's regression folded over the mirror exchange, 907.38 +- 0.09 with k-hat 0.54, but its doubtful quadratures
#: hold 3.6 % of the weight (docs/verification.md, stop 75); with the re-brackets (stop 76) of 4 000 draws of the
#: proposal fitted to the nautilus draws 117 stay doubtful where 410 were, and those 410 gained 71 nats (median);
#: the stage's run, 908.02 +- 0.17, k-hat 0.57, ESS 33 of 30 000, doubtful weight 5e-96: TRUSTED. T1's full model
#: is a sheet across the softer family's ginf and beta (k-hat 1.74 over all 11); with beta3 integrated out on one
#: labelling, 989.22 +- 0.35, k-hat 1.17: still NOT TRUSTED (docs/verification.md, stops 77-78).
COLLAPSED = {("joint", "full"): Collapse("kappa"), ("T1", "full"): Collapse("beta3", zoom=2, one_labelling=True)}
#: A collapsed check's settings per mode: its importance sampling (over the check's own settings; each point costs
#: about 71 likelihood calls, :class:`~bayestissue.inference.sampling.collapsed.LineQuadrature`, so the rounds and
#: the estimate have fewer draws: 5 000 a round and 30 000 in the estimate are 0.36 M and 2.1 M calls, at most 24
#: rounds, about 2.2 minutes a round of one core here; stop 75's 12 rounds still rose, 901.63 to 907.67) and how
#: many draws, resampled by weight and each given a value of the integrated parameter from its conditional (59
#: calls each), its quantiles come from.
COLLAPSED_SETTINGS = {
    "quick": {"importance": {"n_draws": 500, "adapt_draws": 250}, "quantile_draws": 200},
    "full": {"importance": {"n_draws": 30_000, "adapt_draws": 5_000, "adapt_rounds": 24}, "quantile_draws": 4000},
}
#: A collapsed estimate is trusted only if the draws whose line quadrature is doubtful (the peak on its bracket's
#: edge, or not concave) hold less than this share of its normalised weight.
DOUBT_MAX = 0.01
#: The line quadrature's module, in the hash of a collapsed check only (the other checks' hashes stay as they were).
COLLAPSED_MODULE = "inference/sampling/collapsed.py"


def check_hash(mode: str, data_dir: Path, data: str, model: str) -> str:
    """:func:`~bayestissue.analyses.model_choice.numbers_hash` of the current code (the importance sampler included,
    which the nested runs' hash leaves out; the line quadrature only for a :data:`COLLAPSED` check), the data set's
    files, the seed and ``mode``'s settings: it changes with anything the check's numbers depend on."""
    settings = ("importance", CHECK_SEED, model, CANDIDATES[data][model], CHECK_SETTINGS[mode])
    line = COLLAPSED.get((data, model))
    if line is not None:
        settings += (("collapsed", line, COLLAPSED_SETTINGS[mode], DOUBT_MAX),)
    return numbers_hash(data_files(data_dir, data), repr(settings), exclude=() if line else (COLLAPSED_MODULE,))


@dataclass(frozen=True)
class Quadrature:
    """A collapsed check's line quadrature (:class:`~bayestissue.inference.sampling.collapsed.LineQuadrature`):
    ``param`` integrated out, on ``one_labelling`` of the mirror families or the whole box, ``text`` its settings
    and counts in words, over all its points (adaptation and estimate): ``points`` integrated, ``outside`` off the
    labelling (no calls), ``edge`` with the peak on a bracket's edge after the re-brackets, ``flat`` not concave
    after the Newton steps; ``share`` the normalised weight of the estimate's draws that were either."""

    param: str
    one_labelling: bool
    text: str
    points: int
    outside: int
    edge: int
    flat: int
    share: float

    def summary(self) -> str:
        """The settings and counts, and the weight on doubtful points: the verdict's words and the report's."""
        return f"{self.text}, holding {self.share:.2g} of the weight"


@dataclass(frozen=True)
class EvidenceCheck:
    """One model's evidence by importance sampling on one data set.

    ``proposal_*``: the nautilus run whose draws the proposal was fitted to (its own log Z, calls, seconds).
    ``log_z``, ``log_z_err``: the estimate and its delta-method error; ``batch_log_z``/``batch_err`` the 4 batches',
    ``batch_p`` their scatter's p-value; ``k_hat`` the weights' Pareto k-hat, ``ess`` their Kish effective sample
    size of ``n_draws``; ``calls`` the likelihood calls of adaptation and estimate, ``failed`` the failed solves
    among them, ``time_s`` their seconds; ``adapt_log_z`` each adaptation round's estimate (they approach the final
    one as the proposal improves); ``trusted`` and ``verdict`` as
    :class:`~bayestissue.inference.sampling.importance.ImportanceEvidence` says; ``quantiles[j]`` the 5 / 50 / 95 %
    of sampled material parameter ``names[j]`` under the importance weights (folded where families are
    exchangeable); ``swapped`` the two parameter groups the proposal was symmetrised over (:func:`mirror_swap`), or
    none; ``box`` the evidence under narrowed and widened log boxes of the material parameters (module docstring);
    ``quadrature`` a collapsed check's counts (:data:`COLLAPSED`), None for the others."""

    model: str
    numbers_hash: str
    names: list[str]
    proposal_log_z: float
    proposal_calls: int
    proposal_s: float
    log_z: float
    log_z_err: float
    batch_log_z: list[float]
    batch_err: list[float]
    batch_p: float
    k_hat: float
    ess: float
    n_draws: int
    calls: int
    failed: int
    time_s: float
    adapt_log_z: list[float]
    trusted: bool
    verdict: str
    quantiles: list[list[float]]
    swapped: list[list[str]]
    box: BoxShift
    quadrature: Quadrature | None


@dataclass(frozen=True)
class CheckCase:
    """The checked models of one data set (``checks`` by model name)."""

    data: str
    checks: dict[str, EvidenceCheck]

    @property
    def factors_run(self) -> tuple[tuple[str, str], ...]:
        """The data set's factors (:data:`~bayestissue.analyses.model_choice.FACTORS`) whose models are both checked."""
        return tuple((a, b) for a, b in FACTORS[self.data] if a in self.checks and b in self.checks)

    def log_bayes(self, a: str, b: str) -> tuple[float, float]:
        """:math:`\\ln B` of ``a`` over ``b`` and its error: the two delta-method errors and :data:`PROPOSAL_ERROR`
        for each evidence, in quadrature (module docstring)."""
        x, y = self.checks[a], self.checks[b]
        return float(x.log_z - y.log_z), float(np.sqrt(x.log_z_err**2 + y.log_z_err**2 + 2 * PROPOSAL_ERROR**2))

    def factor(self, a: str, b: str) -> dict:
        """ln B of ``a`` over ``b``, the model it favours, its grade, whether both estimates are trusted and whether
        it decides (:func:`~bayestissue.analyses.verdicts.evidence_decides`)."""
        log_b, err = self.log_bayes(a, b)
        trusted = self.checks[a].trusted and self.checks[b].trusted
        return {"a": a, "b": b, "log_b": log_b, "err": err, "favours": a if log_b > 0 else b,
                "grade": evidence_strength(abs(log_b), err), "trusted": trusted,
                "decides": evidence_decides(log_b, err, trusted)}  # fmt: skip

    def box_moves(self, a: str, b: str) -> dict[str, tuple[float, float]]:
        """How :math:`\\ln B` of ``a`` over ``b`` moves (value, error) when every log box is narrowed
        (``"narrowed"``) or widened (``"widened_volume"``, ``"widened_flat"``; no Monte Carlo error), as
        :meth:`~bayestissue.analyses.model_choice.DataChoice.log_bayes_moves` says for the nested runs."""
        x, y = self.checks[a].box, self.checks[b].box
        return {
            "narrowed": (x.narrowed[0] - y.narrowed[0], float(np.hypot(x.narrowed[1], y.narrowed[1]))),
            "widened_volume": (x.widened_volume - y.widened_volume, 0.0),
            "widened_flat": (x.widened_flat - y.widened_flat, 0.0),
        }


@dataclass(frozen=True)
class EvidenceCheckRecord:
    """The evidence-check stage's record: one :class:`CheckCase` per data set checked, in
    :data:`~bayestissue.analyses.model_choice.DATASETS` order."""

    SCHEMA: ClassVar[str] = "bayestissue.evidence_check"
    VERSION: ClassVar[int] = 4
    mode: str
    cases: dict[str, CheckCase]

    def ordered(self) -> list[CheckCase]:
        return [self.cases[d] for d in DATASETS if d in self.cases]


#: log-likelihoods of a draw and its mirror image that differ by more than this (nats) break the symmetry
#: :func:`mirror_swap` assumes (measured on the joint full model: at most 5e-12 over 200 posterior draws, round-off)
SYMMETRY_TOL = 1e-6


def mirror_swap(names, log_l_unit, unit_draws) -> tuple[tuple[int, ...], tuple[int, ...]] | None:
    """The index groups of fibre families 2 and 3 (:data:`~bayestissue.paper.MIRROR_TIES`) among the sampled
    parameters ``names`` when both are sampled (the full model) and exchanging them leaves ``log_l_unit`` unchanged
    within :data:`SYMMETRY_TOL` at the first 16 of ``unit_draws`` (``(n, d)``, unit-cube coordinates); None
    otherwise (a tied model, or directions that are not mirror images)."""
    b_names, a_names = zip(*MIRROR_TIES, strict=True)
    if not set(a_names + b_names) <= set(names):
        return None
    swap = (tuple(names.index(n) for n in a_names), tuple(names.index(n) for n in b_names))
    u = np.asarray(unit_draws, dtype=float)[:16]
    gap = np.max(np.abs(log_l_unit(u) - log_l_unit(swapped(u, swap))))
    return swap if gap <= SYMMETRY_TOL else None


def proposal_hash(mode: str, data_dir: Path, data: str, model: str, seed: int) -> str:
    """:func:`~bayestissue.analyses.model_choice.numbers_hash` of what the nautilus run behind a check depends on:
    the nested code (not the importance sampler, :data:`~bayestissue.analyses.model_choice.NOT_NESTED`), the data
    set's files, the seed and ``mode``'s proposal settings. A change of the importance sampler alone keeps it, so
    that a rerun of the checks takes the runs' draws from the cache (:func:`proposal_run`)."""
    settings = repr(("proposal", seed, model, CANDIDATES[data][model], CHECK_SETTINGS[mode]["proposal"]))
    return numbers_hash(data_files(data_dir, data), settings)


def check_model(problem, data_dir: Path, data: str, model: str, mode: str, seed: int, progress,
                cache: Path | None = None) -> EvidenceCheck:  # fmt: skip
    """One model's check on the data set ``data`` (its files in ``data_dir``, for the hash): the nautilus run (from
    ``cache`` when an earlier stage ran it under the same :func:`proposal_hash`), the proposal fitted to its draws,
    importance sampling (module docstring); ``progress(line)`` says where it is (every 20 000 nautilus calls, every
    adaptation round)."""
    settings = CHECK_SETTINGS[mode]
    opts = NestedOptions(**settings["proposal"], n_processes=1, report_every=20_000)
    key = proposal_hash(mode, data_dir, data, model, seed)
    path = None if cache is None else Path(cache) / f"proposal_{mode}_{data}_{model}_{key}.npz"
    run = proposal_run(problem, opts, seed, path, lambda line: progress(f"{data} {model}: {line}"))
    how = "read from the cache" if run.cached else "run"
    progress(f"{data} {model}: nautilus {run.calls} calls, {run.time_s:.0f} s ({how}), its log Z {run.log_z:.3f}; "
             "importance sampling")  # fmt: skip
    n_dim, prior, log_l, _ = nested_target(problem, opts)
    u, w = pooled_unit_draws(problem, [run.points], [run.weights])
    names = list(problem.material.sampled_names)

    def log_l_unit(x):
        return log_l(prior(x))

    swap = mirror_swap(names, log_l_unit, u[np.argsort(w)[::-1]])
    iopts = ImportanceOptions(**settings["importance"])
    collapse, outside = COLLAPSED.get((data, model)), None
    if collapse is None:
        target, draws, proposal_swap = log_l_unit, u, swap
    else:  # one parameter integrated out by quadrature, the proposal over the others (COLLAPSED)
        iopts = ImportanceOptions(**{**settings["importance"], **COLLAPSED_SETTINGS[mode]["importance"]})
        k = names.index(collapse.param)
        proposal_swap = None if swap is None else tuple(tuple(i - (i > k) for i in g) for g in swap)
        labelling = None
        if collapse.one_labelling:  # the draws folded onto family 2 not softer; the proposal not symmetrised
            if swap is None:
                raise ValidationError(f"{data} {model} check", "one labelling", "a model with mirror families")
            labelling = (proposal_swap[0][0], proposal_swap[1][0])
            u, proposal_swap, swap = folded(u, swap), None, None
        line = fit_line(u, w, k, swap=proposal_swap, seed=seed, zoom=collapse.zoom, labelling=labelling)
        target, draws = line.collapsed(log_l_unit), np.delete(u, k, axis=1)
        if labelling is not None:  # zero likelihood off the labelling by construction: not failed solves

            def outside(unit_rest):
                return ~line.inside(unit_logit(unit_rest))

        progress(f"{data} {model}: {collapse.param} integrated out by quadrature (regression's largest residual "
                 f"{line.residual_max:.3g}, bracket +-{line.window:.3g})")  # fmt: skip
    proposal = fit_unit_proposal(draws, iopts, weights=w, seed=seed, swap=proposal_swap)

    def rounds(stage, done, total):  # one line per adaptation round and one for the estimate's draws
        if done == total:
            of = f" of at most {iopts.adapt_rounds}" if stage.startswith("adapt") else ""
            progress(f"{data} {model}: importance sampling, {stage}{of} done ({total} draws)")

    res = importance_evidence(target, proposal, iopts, rng=seed, progress=rounds, outside=outside)
    wn = np.exp(res.log_w)
    trusted, verdict, quad = res.trusted, res.verdict(), None
    if collapse is None:
        unit = res.unit
    else:  # quantiles from draws resampled by weight, each with the integrated parameter from its conditional
        share = float(wn[line.last_doubtful(res.n_draws)].sum())
        quad = Quadrature(collapse.param, labelling is not None, line.text(), line.points, line.outside, line.edge,
                          line.flat, share)  # fmt: skip
        verdict += f"; {collapse.param} by quadrature: {quad.summary()}"
        if share >= DOUBT_MAX:
            trusted = False
            verdict += f" (NOT TRUSTED: at least {DOUBT_MAX:g})"
        gen = np.random.default_rng(seed)
        pick = gen.choice(res.n_draws, size=COLLAPSED_SETTINGS[mode]["quantile_draws"], p=wn / wn.sum())
        m, sd = line.last_peaks(res.n_draws)  # the estimate's own quadratures: no new calls
        unit, wn = line.draw_at(res.unit[pick], m[pick], sd[pick], gen), np.full(pick.size, 1.0 / pick.size)
    check_key = check_hash(mode, data_dir, data, model)  # of the code as it is when the check ends
    if cache is not None:  # the estimate's weighted draws, for a look at where its weight sits
        Path(cache).mkdir(parents=True, exist_ok=True)
        np.savez(Path(cache) / f"draws_{mode}_{data}_{model}_{check_key}.npz", unit=res.unit, log_w=res.log_w,
                 names=np.array([n for n in names if collapse is None or n != collapse.param]))  # fmt: skip
    x = prior(unit)
    box = box_shift_weighted(x, wn, res.ess, problem.parameters.sampled[:n_dim])
    padded = np.zeros((x.shape[0], problem.ndim))
    padded[:, :n_dim] = x
    canon = problem.canonical(padded)[:, :n_dim]
    q = [weighted_quantile(canon[:, j], wn, LEVELS).tolist() for j in range(n_dim)]
    progress(f"{data} {model}: {verdict}")
    return EvidenceCheck(model=model, numbers_hash=check_key,
                         names=names, proposal_log_z=run.log_z, proposal_calls=run.calls,
                         proposal_s=run.time_s, log_z=res.log_z,
                         log_z_err=res.log_z_err, batch_log_z=res.batch_log_z.tolist(),
                         batch_err=res.batch_err.tolist(), batch_p=res.batch_p, k_hat=res.k_hat, ess=res.ess,
                         n_draws=res.n_draws, calls=res.n_calls if collapse is None else line.calls,
                         failed=res.n_failed, time_s=res.time_s,
                         adapt_log_z=list(res.adapt_log_z),
                         trusted=trusted, verdict=verdict, quantiles=q,
                         swapped=[[names[i] for i in g] for g in swap or ()], box=box,
                         quadrature=quad)  # fmt: skip


class DataProblems:
    """The calibration problems of one data set's ``models`` by name (:func:`~.model_choice.model_problem`), handed
    to forked workers as one object (:func:`check_task`); ``cache`` the folder each finished check is written to
    (:func:`cached_check`), None for none."""

    def __init__(self, data_dir: Path, data: str, models, cache: Path | None = None):
        self.data_dir, self.data, self.cache = Path(data_dir), data, cache
        self.by_model = {m: model_problem(self.data_dir, data, m) for m in models}


def _cache_path(cache: Path, mode: str, data: str, model: str, key: str) -> Path:
    return Path(cache) / f"{mode}_{data}_{model}_{key}.json"


def cached_check(cache: Path | None, mode: str, data: str, model: str, key: str) -> EvidenceCheck | None:
    """The check of ``model`` on ``data`` that an earlier (perhaps killed) stage finished under the hash ``key``, or
    None: a stage that is killed loses no model it had finished, and a check of other code is never taken."""
    if cache is None or not _cache_path(cache, mode, data, model, key).is_file():
        return None
    try:
        rec = read_record(_cache_path(cache, mode, data, model, key), EvidenceCheckRecord)
    except RecordError:  # another version's record
        return None
    found = rec.cases[data].checks[model]
    return found if found.numbers_hash == key else None


def check_task(problems: DataProblems, model: str, mode: str, seed: int, progress) -> EvidenceCheck | str:
    """A worker's task (:func:`~bayestissue.inference.sampling.processes.run_in_processes`): one model's check, written
    to the cache as soon as it is done, or the one-line error that stopped it (so that one model's failure does not
    lose the others' work)."""
    try:
        check = check_model(
            problems.by_model[model], problems.data_dir, problems.data, model, mode, seed, progress, problems.cache
        )
    except Exception as err:  # noqa: BLE001 -- reported by the stage, which records the models that finished
        return f"{type(err).__name__}: {err}"
    if problems.cache is not None:
        Path(problems.cache).mkdir(parents=True, exist_ok=True)
        one = EvidenceCheckRecord(mode=mode, cases={problems.data: CheckCase(problems.data, {model: check})})
        write_record(_cache_path(problems.cache, mode, problems.data, model, check.numbers_hash), one)
    return check
