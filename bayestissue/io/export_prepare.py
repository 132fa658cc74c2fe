r"""A machine export's curve made ready for the model: tare, failure cut, slips flagged, resampling; each step says
what it did (``bayestissue import`` prints it and writes it into the experiment's header).

* **Tare** (``tare=True``): the model starts unloaded, a gripped specimen often does not (a preload of a few mN).
  The load of the samples before the extension first moves (the first sample at least) is averaged and subtracted.
  Without tare the preload is kept and reported.
* **Failure vs relaxation.** A failure is a *sudden* fall of the load while the extension rises or holds; a
  stress-relaxation hold is a *gradual* decay at constant extension, and may well end below half the peak. A sudden
  fall is one of more than ``drop`` (default 0.15) of the load within :func:`fall_window` (three samples, at least
  0.1 s), from a load of at least :data:`MIN_LOAD` of the peak (noise near zero load is no fall), with the extension
  not decreasing meanwhile. If the load later climbs back above its level before the fall, it was a **slip** in the
  grips: flagged, the data kept. Otherwise it is the failure: the samples from the fall on are cut. A relaxation
  branch of amplitude a and time constant tau falls by a (1 - exp(-0.3 s / tau)) in 0.3 s: 0.13 for a = 0.5,
  tau = 1 s, the fastest reported for tendon fascicles (issue 32: 1-4 s); a hold relaxing to 0.51 of its peak over
  minutes is not cut.
* **Resampling** (``step_s``): the same number of samples as a uniform step would give, but placed at equal arc
  length of the curve in normalised time, extension and load, so that the ramp and the early hold (where the load
  changes fast) keep their detail and the long flat end of a hold is thinned; the samples kept are measured ones
  (no interpolation: the peak is never clipped; the first, the last and the peak sample are always kept). The
  largest change is reported: the largest distance of a dropped sample's load from the line through the kept ones,
  as a share of the peak load.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError

__all__ = ["DROP", "MIN_LOAD", "fall_window", "find_falls", "prepare", "resample_by_arc_length", "tare_load"]

#: A failure or slip: the load falls by more than this share of its value within :func:`fall_window` ...
DROP = 0.15
#: ... from a load of at least this share of the peak.
MIN_LOAD = 0.05
#: ... within this many samples, and at least :data:`MIN_WINDOW_S`.
WINDOW_SAMPLES = 3
MIN_WINDOW_S = 0.1


def fall_window(t: np.ndarray) -> int:
    """Samples within which a fall counts as sudden: :data:`WINDOW_SAMPLES`, or more where the sampling is faster
    than :data:`MIN_WINDOW_S` over that many samples."""
    step = float(np.median(np.diff(t)))
    return max(WINDOW_SAMPLES, int(np.ceil(MIN_WINDOW_S / step)))


def tare_load(t: np.ndarray, u: np.ndarray, f: np.ndarray) -> tuple[float, int]:
    """The preload: the mean load of the samples before the extension first moves (by more than 1e-6 of its range),
    and their number (at least the first sample)."""
    moved = np.flatnonzero(np.abs(u - u[0]) > 1e-6 * max(np.ptp(u), 1e-12))
    n = int(moved[0]) if moved.size else u.size
    n = max(n, 1)
    return float(np.mean(f[:n])), n


def find_falls(t, u, f, drop: float = DROP) -> list[tuple[int, int, bool]]:
    """Sudden falls of the load (module docstring): ``(start, end, recovered)`` sample indices of each, ``end`` the
    first sample below ``(1 - drop) f[start]``; ``recovered`` if the load later climbs above ``f[start]`` (a slip).
    Falls while the extension decreases (unloading) are not counted."""
    peak = float(np.max(f))
    if not peak > 0.0:
        return []
    w = fall_window(t)
    falls, i, n = [], 0, f.size
    while i < n - 1:
        stop = min(i + w, n - 1)
        below = np.flatnonzero(f[i + 1 : stop + 1] < (1.0 - drop) * f[i])
        if f[i] >= MIN_LOAD * peak and below.size and u[i + 1 + below[0]] >= u[i] - 1e-9 * max(np.ptp(u), 1e-12):
            end = i + 1 + int(below[0])
            falls.append((i, end, bool(np.any(f[end:] > f[i]))))
            i = end
            continue
        i += 1
    return falls


def resample_by_arc_length(t, u, f, n: int) -> tuple[np.ndarray, float]:
    """Indices of ``n`` samples at equal arc length of the curve in normalised (t, u, f) (module docstring), and the
    largest change: the largest |f - interpolation through the kept samples| over all samples, over the peak."""
    if n >= t.size:
        return np.arange(t.size), 0.0

    def norm(x):
        return (x - x[0]) / max(np.ptp(x), 1e-300)

    s = np.concatenate([[0.0], np.cumsum(np.sqrt(np.diff(norm(t)) ** 2 + np.diff(norm(u)) ** 2
                                                 + np.diff(norm(f)) ** 2))])  # fmt: skip
    targets = np.linspace(0.0, s[-1], n)
    nearest = np.searchsorted(s, targets).clip(0, t.size - 1)
    keep = np.unique(np.concatenate([nearest, [0, t.size - 1, int(np.argmax(f))]]))
    change = np.max(np.abs(f - np.interp(t, t[keep], f[keep]))) / max(float(np.max(np.abs(f))), 1e-300)
    return keep, float(change)


#: Fewest steps a resampled curve keeps: a ``--step-s`` over half the test leaves no curve to fit and is refused.
MIN_RESAMPLED = 2


def prepare(export, *, until_s=None, drop: float | None = DROP, tare: bool = False, step_s=None) -> tuple[dict, list]:
    """Tare, cut and resample ``export`` (module docstring). Returns the tidy columns ``time_s``,
    ``displacement_mm``, ``force_mN`` and the list of what was done (one sentence each)."""
    name = Path(export.source).name
    t, u, f = export.time_s, export.extension_mm, export.force_mN
    notes = []
    pre, n_pre = tare_load(t, u, f)
    peak = float(np.max(f))
    if tare:
        f = f - pre
        notes.append(f"tare: subtracted the preload {pre:.4g} mN (the load before the extension moves, "
                     f"{n_pre} sample{'s' if n_pre > 1 else ''}; {pre / peak:.1%} of the peak)")  # fmt: skip
    elif abs(pre) > 0.0:
        notes.append(f"preload {pre:.4g} mN at zero extension kept ({pre / peak:.1%} of the peak; --tare subtracts "
                     "it)")  # fmt: skip
    keep = np.ones(t.size, dtype=bool)
    if until_s is not None:
        keep &= t <= until_s
        notes.append(f"cut at t = {until_s:g} s")
    if drop is not None:
        for start, end, recovered in find_falls(t[keep], u[keep], f[keep], drop):
            what = f"load {f[start]:.4g} -> {f[end]:.4g} mN between t = {t[start]:.4g} and {t[end]:.4g} s"
            if recovered:
                notes.append(f"SLIP flagged (data kept): {what}, then the load climbed back; check the grips")
            else:
                notes.append(f"failure cut: {what} with the extension not decreasing; the samples from "
                             f"t = {t[end]:.4g} s on are dropped")  # fmt: skip
                keep &= np.arange(t.size) < end
                break
    t, u, f = t[keep], u[keep], f[keep]
    if t.size < 2:
        raise ValidationError(f"{name} rows left after trimming", t.size, "at least 2")
    if step_s is not None:
        if step_s > t[-1] / MIN_RESAMPLED:
            raise ValidationError("--step-s", step_s, f"a step of at most {t[-1] / MIN_RESAMPLED:.4g} s ({name} keeps "
                                  f"{t[-1]:.4g} s: at least {MIN_RESAMPLED} steps)")  # fmt: skip
        n = max(int(np.ceil(t[-1] / step_s)) + 1, 3)
        idx, change = resample_by_arc_length(t, u, f, n)
        if idx.size < t.size:
            notes.append(f"resampled to {idx.size} of {t.size} samples, denser where the load changes (as many as a "
                         f"{step_s:g} s step); largest change {change:.2%} of the peak load")  # fmt: skip
        t, u, f = t[idx], u[idx], f[idx]
    return {"time_s": t, "displacement_mm": u, "force_mN": f}, notes
