"""Report sections 2, 3 and 5: is the T1/T2 difference real, which cause, and what experiment would resolve it.

The cause verdict is the controlled rules' (:func:`bayestissue.analyses.verdicts.controls_verdict`, applied here to
every pair of the controls record and to the data files); the per-cause analyses of the T1-vs-T2 record are reported
as measurements beside it.
"""

from __future__ import annotations

import numpy as np

from bayestissue.analyses import verdicts
from bayestissue.analyses.discrepancy import VISC
from bayestissue.analyses.records import ControlsRecord, DiscrepancyRecord, IdentifiabilityRecord

__all__ = ["controls_context", "difference_context", "experiments_context", "rates_context", "specimens_context"]


def difference_context(D: DiscrepancyRecord) -> dict:
    """Section 2: tension, cross-prediction, PSIS, principal angles, overlap, and the verdict."""
    cp = D.cross_prediction
    real = verdicts.difference_is_real(D.tension.p_value, [cp["T2|T1"].coverage, cp["T1|T2"].coverage])
    return {"real": real, "cp": cp}


def controls_context(K: ControlsRecord) -> dict:
    """The controlled rules on every pair of the controls and on the data files."""
    judged = [(p.scenario, p.planted, _verdict(p.fit, K.n_shared)) for p in K.pairs]
    table = verdicts.confusion(judged)
    strengths = {s.name: s.strength for s in K.scenarios}
    rows = []
    for name, row in table.items():
        qs = [v.Q for s, _, v in judged if s == name]
        rows.append({
            "name": name, "planted": " + ".join(verdicts.CAUSES[k] for k in row["planted"]) or "none",
            "strength": strengths[name], "q": (min(qs), max(qs)),
            "verdicts": "; ".join(f"{verdicts.verdict_text(k)}: {n}" for k, n in row["verdicts"].items()),
            "found": row["named"], "n": row["n"], "planted_causes": row["planted"],
            "met": verdicts.planted_found(row["named"], row["n"]),
        })  # fmt: skip
    negative = [v for _, planted, v in judged if not planted]
    planted = [r for r in rows if r["planted_causes"]]
    law = [v.Q for _, planted, v in judged if list(planted) == [1]]
    data = _verdict(K.data, K.n_shared)
    return {
        "rows": rows,
        "n_negative": len(negative),
        "false_differences": sum(v.different for v in negative),
        "planted": planted,
        "n_planted_runs": sum(r["n"] for r in planted),
        "n_found": sum(r["found"] for r in planted),
        "met": [r["name"] for r in planted if r["met"]],
        "not_met": [r["name"] for r in planted if not r["met"]],
        "indistinguishable": sorted({k for row in table.values() for k in row["verdicts"] if "indistinguishable" in k}),
        "law_q": (min(law), max(law)) if law else None,
        "q_threshold": verdicts.tension_threshold(K.n_shared),
        "data": data,
        "data_named": " + ".join(verdicts.CAUSES[k] for k in data.named),
        "data_honest": data.kind in ("partial", "unexplained"),
    }


def _verdict(fit, n_shared):
    return verdicts.controls_verdict(fit.chi2, fit.extra, fit.specimen, fit.n, n_shared=n_shared)


def _side(ci) -> tuple[str, float | None, float | None]:
    """How a profile interval reads: closed, open above, open below or open."""
    lo, hi = ci
    if lo is not None and hi is not None:
        return "closed", lo, hi
    if lo is not None:
        return "above", lo, None
    return ("below", None, hi) if hi is not None else ("open", None, None)


def _seen(truths) -> dict:
    """How many of ``truths`` (profiles at T2's rate, one per truth) show gamma2 (its profile bounded on a side) and
    pin beta2 (closed), how many truths there are, and whether the truths disagree (borderline)."""
    sides = [{p: _side(t.ci[p])[0] for p in VISC} for t in truths]
    n, g = len(sides), sum(s["gamma2"] != "open" for s in sides)
    b = sum(s["beta2"] == "closed" for s in sides)
    return {"n": n, "gamma2": g, "beta2": b, "borderline": 0 < g < n or 0 < b < n}


def rates_context(D: DiscrepancyRecord, I: IdentifiabilityRecord) -> dict:
    """The loading-rate study: what a T2-like ramp at f x T2's rate pins down of the fibre viscosity."""
    R = D.rates
    rows, profiled, closed, capped = [], [], [], []
    for f, ramp in zip(R.factors, R.ramp_s, strict=True):
        pr = R.profiles.get(f"{f:g}")
        if pr is not None:
            profiled.append(f)
            if pr.classification["beta2"] == "identifiable":
                closed.append(f)
            if not pr.converged:
                capped.append(f)
        rows.append({"f": f, "ramp_s": ramp, "se": [R.se_log[p][R.factors.index(f)] for p in VISC], "profile": pr})
    se_beta = np.asarray(R.se_log["beta2"], dtype=float)
    names = I.names
    g = names.index("gamma2")
    t2 = I.profile_reference["T2"].theta_final
    at_t2 = R.profiles.get("1")
    draws = sorted(({"truth": d.truth, "ci": d.ci} for d in R.at_t2), key=lambda d: d["truth"]["beta2"])
    return {
        "rows": rows,
        "visc": VISC,
        "closed": closed,
        "open": [f for f in profiled if f not in closed],
        "capped": capped,
        "monotone": closed == sorted(profiled)[: len(closed)],
        "f_best_gn": R.factors[int(np.nanargmin(se_beta))],
        "truth": {"beta": R.truth[names.index("beta2")], "gamma": R.truth[names.index("gamma2")]},
        "at_t2": None if at_t2 is None else {p: _side(at_t2.ci[p]) for p in VISC},
        "draws": draws,
        "seen": _seen([at_t2] + list(R.at_t2) if at_t2 is not None else list(R.at_t2)),
        "open_fast": min((f for f in profiled if f >= 1 and f not in closed), default=None),
        "t2_posterior_gamma": (I.calibration["T2"].q05[g], I.calibration["T2"].q95[g]),
        "t2_ls": {n: t2[names.index(n)] for n in ("gamma2", "beta2", "gamma3", "beta3")},
    }  # fmt: skip


def experiments_context(D: DiscrepancyRecord, rates: dict) -> dict:
    """Section 5: the rate whose profile pins the fibre relaxation rate best (narrowest closed beta2 interval)."""
    widths = {}
    for key, pr in D.rates.profiles.items():
        lo, hi = pr.ci["beta2"]
        if lo is not None and hi is not None:
            widths[float(key)] = float(np.log10(hi / lo))
    if not widths:
        return {"best": None, "f_best_gn": rates["f_best_gn"]}
    best = min(widths, key=widths.get)
    i = D.rates.factors.index(best)
    return {"best": best, "ramp_s": D.rates.ramp_s[i], "width": widths[best], "width_t2": widths.get(1.0),
            "f_best_gn": rates["f_best_gn"]}  # fmt: skip


def specimens_context(D: DiscrepancyRecord) -> dict:
    """The specimen models and the cut posterior: how much of the tension the stiffness scale removes, how much the
    stereological uncertainty changes the T1/T2 overlap (mean over the parameters)."""
    gain = None
    if D.cut is not None:
        gain = float(np.nanmean(np.asarray(D.cut.bc_pooled) - np.asarray(D.bhattacharyya)))
    return {"scale_share": D.scale.delta_chi2 / max(D.tension.Q, 1e-9), "overlap_gain": gain}
