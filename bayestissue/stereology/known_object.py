r"""A known object for checking CE predictors: two balls, sectioned systematically and point
counted.

The reference space is a ball of radius :math:`R`; the phase is a ball of radius :math:`r` whose
centre lies on the sectioning axis at height :math:`c` (:math:`|c| + r \le R`), so its true volume
fraction is :math:`V_V = r^3 / R^3`. Sections perpendicular to :math:`z` at :math:`z_j = -R + u +
jT`, :math:`u \sim U[0, T)`, cut discs of radii :math:`\sqrt{R^2 - z^2}` and :math:`\sqrt{r^2 - (z -
c)^2}`, concentric in the section plane. Each section gets an independent, uniformly placed square
point grid of spacing :math:`d`; the counts are exact lattice-point counts, so the point-counting
noise (the "nugget") is real and not modelled.

Repeating the sampling over many random starts gives the true spread of :math:`\widehat V_V` against
which the predictors of :mod:`bayestissue.stereology.sections` and the bootstraps of
:mod:`bayestissue.stereology.uncertainty` are judged (:func:`ce_check`), as recommended by Gundersen
et al. (1999) and Cruz-Orive (1999). The area functions of balls are smooth with bounded jumps of
the derivative at the poles, the class for which :math:`m = 1` is designed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.stereology.sections import classic_ratio_ce, ratio_ce
from bayestissue.stereology.uncertainty import naive_section_bootstrap

__all__ = ["TwoBallPhantom", "simulate_surs_counts", "ce_check"]


@dataclass(frozen=True)
class TwoBallPhantom:
    """Reference ball of radius ``radius_ref`` holding a phase ball of ``radius_phase`` at height
    ``offset``."""

    radius_ref: float = 1.0
    radius_phase: float = 0.75
    offset: float = 0.2

    def __post_init__(self):
        R = check_positive("radius_ref", self.radius_ref)
        r = check_positive("radius_phase", self.radius_phase)
        if abs(self.offset) + r > R:
            raise ValidationError(
                "offset",
                self.offset,
                f"|offset| + radius_phase <= radius_ref = {R}",
                "the phase must fit",
            )

    @property
    def volume_fraction(self) -> float:
        """True volume fraction r^3 / R^3."""
        return (self.radius_phase / self.radius_ref) ** 3

    def section_radii(self, z) -> tuple[np.ndarray, np.ndarray]:
        """Disc radii (reference, phase) cut by the plane at height ``z`` (0 outside)."""
        z = np.asarray(z, dtype=float)
        rr = np.sqrt(np.clip(self.radius_ref**2 - z**2, 0.0, None))
        rp = np.sqrt(np.clip(self.radius_phase**2 - (z - self.offset) ** 2, 0.0, None))
        return rr, rp


def _lattice_count(rho: np.ndarray, ox: np.ndarray, oy: np.ndarray, d: float, rmax: float) -> np.ndarray:
    """Points of the grid {(ox + i d, oy + j d)} inside discs of radii ``rho`` centred at 0
    (vectorised)."""
    m = int(np.ceil(rmax / d)) + 1
    y = oy[..., None] + d * np.arange(-m, m + 1)  # (..., rows)
    w2 = rho[..., None] ** 2 - y**2
    w = np.sqrt(np.clip(w2, 0.0, None))
    x0 = ox[..., None]
    c = np.floor((w - x0) / d) - np.ceil((-w - x0) / d) + 1
    return np.sum(np.where(w2 >= 0, np.clip(c, 0, None), 0), axis=-1)


def simulate_surs_counts(
    phantom: TwoBallPhantom,
    spacing: float,
    n_starts: int,
    *,
    grid_spacing: float | None = None,
    size_jitter: float = 0.0,
    rng=None,
) -> dict[str, np.ndarray]:
    """Systematic sections with random starts through ``phantom``, point counted.

    Parameters
    ----------
    phantom : the known object.
    spacing : section spacing T (same length unit as the radii).
    n_starts : number of independent random starts.
    grid_spacing : point-grid spacing d; None gives exact areas in units of d^2 = T^2 (no counting
        noise).
    rng : seed or Generator.

    Returns
    -------
    dict with ``counts`` (n_starts, n_max, 2) points on (phase, rest of reference) zero-padded
    beyond each sample's last section, ``n_sections`` (n_starts,), ``starts`` (n_starts,) and ``z``
    (n_starts, n_max).
    """
    T = check_positive("spacing", spacing)
    jit = check_positive("size_jitter", size_jitter, allow_zero=True)
    rng = np.random.default_rng(rng)
    n_starts = int(n_starts)
    scale = 1.0 + jit * rng.random(n_starts) if jit > 0 else np.ones(n_starts)
    R = phantom.radius_ref * scale[:, None]
    n_max = int(np.ceil(2 * R.max() / T)) + 1
    u = T * rng.random(n_starts)
    z = -R + u[:, None] + T * np.arange(n_max)
    inside = z < R
    rr, rp = phantom.section_radii(np.where(inside, z / scale[:, None], phantom.radius_ref))
    rr, rp = rr * scale[:, None], rp * scale[:, None]
    if grid_spacing is None:
        Pref = np.pi * rr**2 / T**2
        Q = np.pi * rp**2 / T**2
    else:
        d = check_positive("grid_spacing", grid_spacing)
        ox, oy = d * rng.random((2,) + z.shape)
        Pref = _lattice_count(rr, ox, oy, d, R.max())
        Q = _lattice_count(rp, ox, oy, d, R.max())
    Pref = np.where(inside, Pref, 0.0)
    Q = np.where(inside, Q, 0.0)
    return {
        "counts": np.stack([Q, Pref - Q], axis=-1),
        "n_sections": inside.sum(axis=1),
        "starts": u,
        "z": z,
    }


def ce_check(
    phantom: TwoBallPhantom,
    spacing: float,
    *,
    grid_spacing: float | None = None,
    size_jitter: float = 0.0,
    n_starts: int = 2000,
    n_naive: int = 50,
    n_boot: int = 400,
    rng=None,
) -> dict[str, float]:
    r"""Compare CE predictors with the true spread of :math:`\widehat V_V` over random starts.

    Returns
    -------
    dict with ``true_ce`` (standard deviation over starts / true V_V), ``bias`` (relative),
    ``n_sections`` (mean), the root-mean-square predicted CE of the ratio form with covariance and
    nugget for ``m0``, ``m1`` and ``q_hat``, ``classic`` (independent units, Cochran) and
    ``naive_bootstrap`` (resampling the sections of each sample, averaged over ``n_naive`` samples).
    Options as :func:`simulate_surs_counts`.
    """
    rng = np.random.default_rng(rng)
    sim = simulate_surs_counts(phantom, spacing, n_starts, grid_spacing=grid_spacing, size_jitter=size_jitter, rng=rng)
    Q = sim["counts"][..., 0]
    P = sim["counts"].sum(axis=-1)
    vv = Q.sum(axis=1) / P.sum(axis=1)
    truth = phantom.volume_fraction
    out = {
        "true_vv": truth,
        "true_ce": float(np.std(vv, ddof=1) / truth),
        "bias": float(np.mean(vv) / truth - 1.0),
        "n_sections": float(np.mean(sim["n_sections"])),
    }
    nug = grid_spacing is not None
    for key, sm in (("m0", 0), ("m1", 1), ("q_hat", "q_hat")):
        ce = ratio_ce(Q, P, smoothness=sm, nugget=nug)
        out[key] = float(np.sqrt(np.mean(ce**2)))
    # the classic CE and the naive bootstrap work on each sample's own sections (no zero padding)
    cl, nb = [], []
    for i in range(min(n_naive, n_starts)):
        k = sim["n_sections"][i]
        q, p = Q[i, :k], P[i, :k]
        cl.append(classic_ratio_ce(q, p))
        draws = naive_section_bootstrap(np.stack([q, p - q], axis=1), n_boot=n_boot, rng=rng)
        nb.append(np.std(draws[:, 0], ddof=1) / (q.sum() / p.sum()))
    out["classic"] = float(np.sqrt(np.mean(np.square(cl))))
    out["naive_bootstrap"] = float(np.sqrt(np.mean(np.square(nb))))
    return out
