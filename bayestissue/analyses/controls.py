r"""Controls for the T1-vs-T2 analysis: test pairs from ONE tissue with each candidate cause planted in turn.

The replicas in ``data/`` come from two different parameter sets, so the study can only show that it finds a
difference that was put there. Here pairs of a T1-like creep test and a T2-like ramp (the paper's protocols,
specimen sizes and data grids, noise sd 0.02 mm as the replicas) are generated from one tissue,
:data:`BASE_PARAMETERS` (the paper's Table 1 T1 estimates with :math:`\beta_3 = \beta_2`, so that the analysed
mirror model is exact when nothing is planted), and each cause of the paper is planted at a stated strength
(:data:`SCENARIOS`):

0. none (negative control);
1. the fibres follow the two-branch law of :mod:`bayestissue.mechanics.branches` (a fast branch beside the paper's
   slow one on families 2 and 3) in both tests, while the analysis fits the paper's law;
2. the T2 specimen's fibre 2/3 half-angle differs (within and beyond the stereological spread, sd 1.4 degrees);
3. the T2 specimen is stiffer by a factor on every modulus;
4. causes 1 and 3 together.

Each pair is analysed by least squares in the mirror model (8 material parameters; the paper's method, multi-start):
T1 alone, T2 alone, both with shared parameters, and a *cause model* per cause and per pair of causes, fitted to
both tests: (1) the two-branch law shared by both, (2) a free T2 fibre half-angle, (3) a T2 stiffness scale
(:class:`~bayestissue.workflows.forward.SpecimenForward`), and (1+2), (1+3), (2+3) together. The decision rules
are :func:`bayestissue.analyses.verdicts.controls_verdict` (their thresholds are named there): a *difference* if the
tension has p < 0.001; a cause model *explains* it if BIC prefers it by more than 10 and its remaining tension has
p >= 0.001 (against :math:`\chi^2_{8 - k_s}`, :math:`k_s` its specimen-level parameters: 1 for causes 2 and 3;
cause 1's extra parameters are shared); single causes first, then pairs that need both causes.

The single-cause rules and every threshold were fixed before the scenarios were first run; the pair step was added
after that run, in which the combination scenario could not be named (0 of 5: no two-cause model), with the
thresholds unchanged. The posterior parts of the study (cross-prediction, cut posteriors) are not rerun per pair: a
pair costs seconds by least squares against minutes of sampling.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bayestissue.analyses.verdicts import CAUSE_MODELS, ControlsVerdict, controls_verdict
from bayestissue.inference import fit_least_squares
from bayestissue.inference.warmstart import latin_hypercube
from bayestissue.mechanics import Experiment, simulate
from bayestissue.mechanics.branches import second_branch_ties, with_second_branch
from bayestissue.paper import MIRROR_TIES, PAPER_HALF_ANGLE_DEG, PAPER_PARAMETERS
from bayestissue.workflows.config import CalibrationConfig
from bayestissue.workflows.forward import tissue_with_half_angle
from bayestissue.workflows.problem import build_problem

__all__ = [
    "BASE_PARAMETERS",
    "N_SHARED",
    "NOISE_SD_MM",
    "SCENARIOS",
    "Scenario",
    "analyse_data",
    "analyse_pair",
    "make_pair",
    "pair_verdict",
    "run_case",
]

#: The one tissue: paper Table 1, T1 estimates, with beta3 = beta2 (mirror-symmetric).
BASE_PARAMETERS = np.array(PAPER_PARAMETERS["T1"], dtype=float)
BASE_PARAMETERS[10] = BASE_PARAMETERS[7]
BASE_PARAMETERS.setflags(write=False)
#: Noise sd of the pairs (mm), as the replicas.
NOISE_SD_MM = 0.02
#: Shared material parameters of the mirror model (the tension's degrees of freedom).
N_SHARED = 8
#: Families that get a second branch (the mirror pair) and that branch's start in the cause-1 fit.
BRANCHED = (2, 3)
_BRANCH_START = (0.01, 0.5, 0.05)


@dataclass(frozen=True)
class Scenario:
    """A planted cause at a stated strength.

    fast_branch : None, or ``(share, gamma, beta)``: families 2 and 3 get a second Kelvin branch whose equilibrium
        modulus is ``share`` times the slow branch's (the slow branch keeps the base law; both carry half the
        fraction, so the slow one has twice the base ginf); both tests.
    angle_deg : added to the T2 specimen's fibre 2/3 half-angle (the base is the paper's 20.05 degrees).
    scale : multiplies every modulus (mu, kappa, ginf_k) of the T2 specimen.
    """

    name: str
    planted: tuple[int, ...]
    fast_branch: tuple[float, float, float] | None = None
    angle_deg: float = 0.0
    scale: float = 1.0

    @property
    def strength(self) -> str:
        parts = []
        if self.fast_branch is not None:
            s, g, b = self.fast_branch
            parts.append(f"fast branch {s:g} x the slow modulus, gamma {g:g}, time {(1 - g) / b:g} s")
        if self.angle_deg:
            parts.append(f"T2 half-angle {self.angle_deg:+g} deg")
        if self.scale != 1.0:
            parts.append(f"T2 moduli x {self.scale:g}")
        return "; ".join(parts) or "nothing planted"


#: The scenarios of the study (strengths stated; the rules above do not depend on them).
SCENARIOS = (
    Scenario("negative control", ()),
    Scenario("fibre law, weak", (1,), fast_branch=(2.0, 0.7, 0.005)),
    Scenario("fibre law, strong", (1,), fast_branch=(2.0, 0.9, 0.1 / 60)),
    Scenario("angle, within stereology", (2,), angle_deg=2.0),
    Scenario("angle, beyond stereology", (2,), angle_deg=10.0),
    Scenario("specimen stiffness", (3,), scale=1.5),
    Scenario("fibre law + stiffness", (1, 3), fast_branch=(2.0, 0.9, 0.1 / 60), scale=1.3),
)


def _noisy(e: Experiment, tissue, params, rng) -> Experiment:
    u = simulate(replace(e, tissue=tissue), np.asarray(params, dtype=float))
    y = u + NOISE_SD_MM * rng.normal(size=u.shape)
    y[0] = 0.0  # the unloaded reference state is known exactly (as the replicas)
    return replace(
        e,
        displacement_mm=y,
        noise_sd_mm=NOISE_SD_MM,
        synthetic=True,
        description=f"SYNTHETIC control pair ({e.name}-like test; bayestissue.analyses.controls), not measured data",
        source=None,
        data_file=None,
        meta={"synthetic": "yes -- control pair (bayestissue.analyses.controls)"},
    )


def make_pair(t1: Experiment, t2: Experiment, scenario: Scenario, seed: int) -> tuple[Experiment, Experiment]:
    """A T1-like and a T2-like test (protocols, sizes and grids of ``t1``, ``t2``) from :data:`BASE_PARAMETERS`
    with ``scenario``'s cause planted, plus seeded Gaussian noise of sd :data:`NOISE_SD_MM`."""
    rng = np.random.default_rng([int(seed), 22])
    p = BASE_PARAMETERS.copy()
    tissue = t1.tissue
    tissue2 = tissue
    if scenario.angle_deg:
        tissue2 = tissue_with_half_angle(tissue, PAPER_HALF_ANGLE_DEG + scenario.angle_deg)
    if scenario.fast_branch is not None:
        share, gamma, beta = scenario.fast_branch
        tissue, tissue2 = (with_second_branch(t, BRANCHED) for t in (tissue, tissue2))
        slow = [2 * p[5], p[6], p[7]]  # half the fraction: twice the modulus keeps the slow branch's stress
        fast = [2 * p[5] * share, gamma, beta]
        p = np.concatenate([p[:5], slow, slow, fast, fast])
    p2 = p.copy()
    p2[tissue.modulus_indices()] *= scenario.scale
    return _noisy(t1, tissue, p, rng), _noisy(t2, tissue2, p2, rng)


def _fit(experiments, starts, *, tied=MIRROR_TIES, specimen=None, n_lhs=0, seed=0):
    """Best of bounded least-squares fits (scaled box, the warm start's settings) from ``starts`` plus ``n_lhs``
    Latin-hypercube starts; returns (chi2, estimate)."""
    config = CalibrationConfig(tied=dict(tied), noise="gaussian", noise_options={"sd": NOISE_SD_MM}, specimen=specimen)
    problem = build_problem(experiments, config)
    mat = problem.material
    x0 = [np.clip(np.asarray(s, dtype=float), mat.lower, mat.upper) for s in starts]
    if n_lhs:
        x0 += list(mat.from_unit(0.02 + 0.96 * latin_hypercube(n_lhs, mat.n_sampled, rng=seed)))
    jac = "differences" if specimen is not None else "exact"
    best = min(
        (fit_least_squares(problem, x, space="unit", jacobian=jac, max_nfev=400) for x in x0), key=lambda r: r.cost
    )
    return 2.0 * float(best.cost), best.x


#: Cause models: key -> causes it contains (singles, then pairs).


def _cause_model(e1, e2, optima, causes, seed):
    """Fit the cause model ``causes`` to the pair from the base optima; returns chi2 (module docstring)."""
    kinds = "+".join(k for c, k in ((2, "angle"), (3, "scale")) if c in causes) or None
    extra = [v for c, v in ((2, PAPER_HALF_ANGLE_DEG), (3, 1.0)) if c in causes]
    tied, starts, n_lhs = MIRROR_TIES, [np.append(x, extra) for x in optima], 0
    if 1 in causes:
        e1, e2 = (replace(e, tissue=with_second_branch(e.tissue, BRANCHED)) for e in (e1, e2))
        tied, n_lhs = second_branch_ties(MIRROR_TIES, e1.tissue), 2
        # the slow branch from a base optimum (half the fraction: twice ginf), the fast one small
        starts = [np.concatenate([x[:5], [2 * x[5], x[6], x[7]], _BRANCH_START, extra]) for x in optima]
    specimen = None if kinds is None else (kinds, e2.name)
    return _fit([e1, e2], starts, tied=tied, specimen=specimen, n_lhs=n_lhs, seed=seed)


def analyse_pair(e1: Experiment, e2: Experiment, *, seed: int = 0) -> dict:
    """Least squares of the pair: T1, T2, joint, and the cause models of :data:`CAUSE_MODELS` (module docstring).

    Starts: the paper's initial guess and 4 Latin-hypercube points for each test alone; for the joint fit those
    two optima, the initial guess and 2 more points; each cause model from the joint and the two separate optima
    (the specimen parameters at 1 and the paper's angle; a second branch starting small, ginf 0.01, gamma 0.5,
    beta 0.05, plus 2 random points). The pair models are fitted only when the rules reach them (no single cause
    explains a difference). Returns the chi-square values, the specimen estimates of the single-cause models, the
    extra and specimen-level parameter counts and the data size.
    """
    init = build_problem([e1], CalibrationConfig(tied=dict(MIRROR_TIES))).material.initial
    c1, x1 = _fit([e1], [init], n_lhs=4, seed=seed)
    c2, x2 = _fit([e2], [init], n_lhs=4, seed=seed + 1)
    cj, xj = _fit([e1, e2], [init, x1, x2], n_lhs=2, seed=seed + 2)
    fit = {
        "chi2": {"T1": c1, "T2": c2, "joint": cj},
        "extra": {k: 3 * (1 in c) + (2 in c) + (3 in c) for k, c in CAUSE_MODELS.items()},
        "specimen": {k: (2 in c) + (3 in c) for k, c in CAUSE_MODELS.items()},
        "n": int(e1.time_s.size + e2.time_s.size),
    }
    singles = [k for k, c in CAUSE_MODELS.items() if len(c) == 1]
    for key in singles:
        fit["chi2"][key], x = _cause_model(e1, e2, (xj, x1, x2), CAUSE_MODELS[key], seed + 3)
        if key in ("2", "3"):
            fit["angle_deg" if key == "2" else "scale"] = float(x[-1])
    if pair_verdict(fit).kind in ("no difference", "named", "indistinguishable"):
        return fit  # the rules never look at the pairs then
    for key in (k for k in CAUSE_MODELS if k not in singles):
        fit["chi2"][key], _ = _cause_model(e1, e2, (xj, x1, x2), CAUSE_MODELS[key], seed + 3)
    return fit


def run_case(scenario: Scenario, seed: int, t1: Experiment, t2: Experiment) -> dict:
    """One pair of ``scenario`` at noise seed ``seed``, analysed (a task for the study's fan-out)."""
    a, b = make_pair(t1, t2, scenario, seed)
    fit = analyse_pair(a, b, seed=seed)
    return {"scenario": scenario.name, "planted": list(scenario.planted), "seed": int(seed), "fit": fit}


def analyse_data(t1: Experiment, t2: Experiment) -> dict:
    """The same analysis on the data files themselves (a task for the study's fan-out)."""
    return {"scenario": "data", "planted": [], "seed": 0, "fit": analyse_pair(t1, t2, seed=0)}


def pair_verdict(fit: dict) -> ControlsVerdict:
    """The controlled rules (:func:`bayestissue.analyses.verdicts.controls_verdict`) on one :func:`analyse_pair`
    result."""
    return controls_verdict(fit["chi2"], fit["extra"], fit["specimen"], fit["n"], n_shared=N_SHARED)
