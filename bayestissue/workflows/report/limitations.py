"""Report end: limitations and the timings of the runs that wrote the summaries."""

from __future__ import annotations

from bayestissue.workflows.report.text import num

__all__ = ["limitations_section"]


def limitations_section(A: dict, B: dict, C, w) -> None:
    """Write the limitations and timings with ``w``."""
    labs = ("T1", "T2", "joint")
    w("## Limitations\n")
    unconverged = [lab for lab in labs if "NOT CONVERGED" in str(A["calibration"][lab].get("sampler", ""))]
    w(
        "- The posteriors come from the mirror model (family 3 tied to family 2): the data cannot tell the two "
        "families apart (exchange symmetry above), but two different relaxation laws summed are not one. "
        + (
            f"Not converged at the step cap: {', '.join(unconverged)}; read their verdicts above before their numbers. "
            if unconverged
            else "Every posterior met the convergence verdict. "
        )
        + "`--full` runs longer chains, more profile steps, 13 rates and 40 replicates."
    )
    w(
        "- The cut posterior per replicate is one ensemble of fixed length (no R-hat); it pools "
        f"{C['n_used'] if C else 'n/a'} of the table's replicates (`--full`: 40)."
    )
    w(
        "- Profiles are relative to the best optimum found (multi-start least squares, then restarts from any "
        "profile point that improved on it by more than 1e-3): a global optimum is still not guaranteed, only "
        "that no profile found a better one. The content-hash cache keys include a hash of the package source "
        f"(`{A.get('cache_salt', '?')}`), so results of older code are never reused."
    )
    w(
        "- Least squares, profiles, sensitivities and the replicate chains assume Gaussian noise with the known sd "
        "(0.02 mm, from the synthetic data files); the calibration posteriors sample the sd."
    )
    w("")
    w("## Timings (s)\n")
    w(
        "Of the run that wrote the summaries (finished tasks come from the content-hash cache and take ~0 s on "
        "a re-run; see the study logs for the cold-cache times).\n"
    )
    for k, v in A["timings_s"].items():
        w(f"- identifiability / {k}: {num(v, '.1f')}")
    for k, v in B["timings_s"].items():
        w(f"- t1_vs_t2 / {k}: {num(v, '.1f')}")
