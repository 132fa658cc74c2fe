"""Report section 1 and 4: which parameters each test identifies, and the point estimates against the posteriors.

Builds the template's values from the identifiability and calibration records; every verdict comes from
:mod:`bayestissue.analyses.verdicts`.
"""

from __future__ import annotations

import numpy as np

from bayestissue.analyses import verdicts
from bayestissue.analyses.identifiability import FIBRE1_NAMES
from bayestissue.analyses.records import CalibrationRecord, IdentifiabilityRecord
from bayestissue.paper import PAPER_PARAMETERS
from bayestissue.report.format import likelihood_ratio, num
from bayestissue.report.study import LABELS

__all__ = ["estimates_context", "identify_context", "identified"]

CLASSES = ("identifiable", "practically non-identifiable", "structurally non-identifiable")


def identified(I: IdentifiabilityRecord, lab: str) -> list[str]:
    """The parameters whose profile closes on both sides in test ``lab``."""
    return [p.name for p in I.profiles[lab] if p.classification == "identifiable"]


def _restart(I: IdentifiabilityRecord, lab: str) -> dict | None:
    """What the profile restarts of ``lab`` moved, and whether it matters (None without restarts)."""
    r, c = I.profile_reference[lab], I.calibration[lab]
    if not r.n_restarts:
        return None
    x0, x1 = np.asarray(r.theta_calibration), np.asarray(r.theta_final)
    d = r.chi2_calibration - r.chi2_final
    names = I.names
    return {
        "lab": lab,
        "delta": d,
        "ratio": likelihood_ratio(d),
        "moved": [
            f"{n} {num(a)} -> {num(b)}"
            for n, a, b in zip(names, x0, x1, strict=True)
            if abs(np.log10(b / a)) > np.log10(2)
        ],  # fmt: skip
        "outside": [n for j, n in enumerate(names) if not c.q05[j] <= x1[j] <= c.q95[j]],
        "matters": verdicts.improvement_matters(d),
        "tied": bool(c.tied),
        "families": {n: x1[names.index(n)] for n in ("ginf2", "ginf3", "beta2", "beta3")},
        "kappa_interval": (c.q05[names.index("kappa")], c.q95[names.index("kappa")]),
        "kappa_best": x1[names.index("kappa")],
    }


def _fibre1(I: IdentifiabilityRecord) -> dict:
    rows, labs = [], {}
    for lab in LABELS:
        c = I.fibre1[lab]
        for k, n in enumerate(FIBRE1_NAMES):
            rows.append({"lab": lab, "name": n, "sensitivity": c.sensitivity[k], "c": c.contraction_corrected[k],
                         "c_tol": c.tol_contraction[k], "kl": c.kl_corrected[k], "kl_tol": c.tol_kl[k],
                         "passes": c.uninformed[k]})  # fmt: skip
        failed = [n for k, n in enumerate(FIBRE1_NAMES) if not c.uninformed[k]]
        labs[lab] = {"passes": not failed, "failed": failed, "share": c.share_draws_fibre1_tension,
                     "n_draws": c.n_draws, "E22": c.max_E22, "tau1": c.max_tau1_kpa}  # fmt: skip
    first = I.fibre1[LABELS[0]]
    return {"rows": rows, "labs": labs, "n_batches": first.n_batches, "t": first.t}


def _mirror(C: CalibrationRecord | None) -> dict | None:
    """The mirror-model runs of the calibration stage: their table and recovery, and the mirror-vs-full comparison
    of the T1 draws' log-likelihood (None without a calibration record)."""
    if C is None:
        return None
    runs = {lab: C.runs[f"{lab}_mirror"] for lab in ("T1", "T2") if f"{lab}_mirror" in C.runs}
    if not runs:
        return None
    names = []
    for run in runs.values():
        names += [p.name for p in run.parameters if p.name not in names]
    table = []
    for n in names:
        cells = {lab: next((p for p in run.parameters if p.name == n), None) for lab, run in runs.items()}
        table.append({"name": n, "cells": cells})
    recovery = {}
    for lab, run in runs.items():
        missed = [p for p in run.parameters if p.generating is not None and verdicts.informed(p.contraction)
                  and not p.q05 <= p.generating <= p.q95]  # fmt: skip
        bound = [bool(np.isclose(p.generating, [p.lower, p.upper]).any()) for p in missed]
        recovery[lab] = [f"{p.name} ({num(p.generating)}{', on a box bound' if b else ''})"
                         for p, b in zip(missed, bound, strict=True)]  # fmt: skip
    ties = None
    full, mirror = C.runs.get("T1"), C.runs.get("T1_mirror")
    if full and mirror and full.loglik_max is not None and mirror.loglik_max is not None:
        gap = full.loglik_max - mirror.loglik_max
        n_tied = sum(1 for p in full.parameters) - sum(1 for p in mirror.parameters)
        gen = {p.name: p.generating for p in full.parameters}
        p_lr = verdicts.likelihood_ratio_p(gap, n_tied)
        ties = {"full": full, "mirror": mirror, "gap": gap, "df": n_tied, "p": p_lr,
                "rejected": verdicts.ties_rejected(p_lr), "beta2": gen.get("beta2"),
                "beta3": gen.get("beta3")}  # fmt: skip
    return {"labs": list(runs), "runs": runs, "table": table, "recovery": recovery, "ties": ties}


def identify_context(I: IdentifiabilityRecord, C: CalibrationRecord | None) -> dict:
    """The values of section 1."""
    names = I.names
    prof = {lab: {p.name: p for p in I.profiles[lab]} for lab in LABELS}
    changed = [
        (lab, n, c0, prof[lab][n].classification)
        for lab in LABELS
        for n, c0 in I.profile_reference[lab].first_classifications.items()
        if n in prof[lab] and c0 != prof[lab][n].classification
    ]
    pairs = {}
    for lab in LABELS:
        ordered = sorted(I.local[lab].pairs, key=lambda t: -t[1])
        pairs[lab] = [p for p in ordered if np.isfinite(p[1])][:4]
    counts = {lab: {c: sum(p.classification == c for p in I.profiles[lab]) for c in CLASSES} for lab in LABELS}
    misfit = [lab for lab in LABELS if any(f.misfit for f in I.calibration[lab].fit.values())]
    return {
        "names": names,
        "prof": prof,
        "restarts": [r for r in (_restart(I, lab) for lab in LABELS) if r],
        "changed": changed,
        "min_delta": min(p.min_delta for lab in LABELS for p in I.profiles[lab]),
        "pairs": pairs,
        "counts": counts,
        "identified": {lab: identified(I, lab) for lab in LABELS},
        "misfit": misfit,
        "unconverged": [lab for lab in LABELS if not I.calibration[lab].converged],
        "fibre1": _fibre1(I),
        "bounds": {
            lab: (
                [n for n, f in zip(names, I.posterior[lab].at_lower, strict=True) if f],
                [n for n, f in zip(names, I.posterior[lab].at_upper, strict=True) if f],
            )
            for lab in LABELS
        },  # fmt: skip
        "mirror": _mirror(C),
    }


def estimates_context(I: IdentifiabilityRecord) -> dict:
    """Section 4: the paper's Table 1, the best least-squares optimum and the posterior, with reading flags."""
    names = I.names
    tables = {}
    for lab in ("T1", "T2"):
        c, r, pm = I.calibration[lab], I.profile_reference[lab], I.posterior[lab]
        prof = {p.name: p for p in I.profiles[lab]}
        rows, misleads = [], 0
        for j, n in enumerate(names):
            closed = None if n not in prof else prof[n].classification == "identifiable"
            flags = verdicts.posterior_flags(
                ls_at_bound=r.at_bound_final[j] != 0, share_lower=pm.share_lower[j], share_upper=pm.share_upper[j],
                profile_closed=closed, skew=c.skew[j], kurt=c.kurt[j],
            )  # fmt: skip
            misleads += r.at_bound_final[j] != 0 or closed is False
            rows.append({"name": n, "paper": PAPER_PARAMETERS[lab][j], "ls": r.theta_final[j], "median": c.median[j],
                         "q05": c.q05[j], "q95": c.q95[j], "flags": flags})  # fmt: skip
        tables[lab] = {"rows": rows, "misleads": misleads}
    return {"tables": tables, "starts": {lab: I.calibration[lab].ls_start_chi2 for lab in LABELS}}
