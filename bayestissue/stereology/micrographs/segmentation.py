r"""Colour segmentation of Mallory-trichrome micrographs into cavity, collagen (ECM) and muscle (SMC).

Two methods, both with automatic (Otsu) thresholds:

``"deconvolution"`` (default)
    Beer-Lambert optical density :math:`\mathrm{OD} = -\ln((I + 1)/256)` per channel; the two stain
    vectors are measured from the images (Macenko et al. 2009: the plane of the two leading
    singular vectors of the tissue OD, the extreme angles in it); stain amounts by least squares,
    :math:`\mathbf c = \mathrm{OD}\, S^{+}`, each divided by its median where that stain
    dominates. A pixel is cavity when its OD norm is below :math:`t_\mathrm{tissue}`, else SMC
    when its red share :math:`c_r / (c_r + c_b)` exceeds :math:`t_\mathrm{smc}`, else ECM.
``"lab"``
    CIE L*a*b*: cavity where :math:`L^* > t_L`, else SMC where the hue angle
    :math:`h = \operatorname{atan2}(b^*, a^*)` exceeds :math:`t_h` (red: h near +30 degrees, blue:
    h near -70 degrees), else ECM.

:func:`threshold_sensitivity` re-segments with every threshold moved by a fraction of the gap
between its two class medians and reports the volume fractions, the segmentation's sensitivity.

References: Ruifrok & Johnston 2001, Anal. Quant. Cytol. Histol. 23:291 (colour deconvolution);
Macenko et al. 2009, Proc. ISBI, doi:10.1109/ISBI.2009.5193250 (stain vectors from the image);
Otsu 1979, IEEE Trans. SMC 9:62, doi:10.1109/TSMC.1979.4310076.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from skimage.color import rgb2lab
from skimage.filters import threshold_otsu

from bayestissue._validation import ValidationError, check_interval
from bayestissue.stereology.micrographs.phantom import CAVITY, ECM, SMC

__all__ = [
    "Segmentation",
    "check_rgb_stack",
    "optical_density",
    "estimate_stain_vectors",
    "segment_stack",
    "seam_mask",
    "threshold_sensitivity",
    "confusion_matrix",
    "label_fractions",
]

_METHODS = ("deconvolution", "lab")


@dataclass
class Segmentation:
    """Result of :func:`segment_stack`.

    Attributes
    ----------
    labels : (n, H, W) uint8, CAVITY (0) / ECM (1) / SMC (2).
    method : "deconvolution" or "lab".
    thresholds : the two thresholds used (``tissue`` and ``smc`` for deconvolution, ``L`` and
        ``hue`` for Lab).
    stains : (2, 3) unit OD vectors (red = SMC, blue = ECM) for deconvolution, else None.
    spread : for each threshold, the gap between the medians of the two classes it separates
        (the unit of :func:`threshold_sensitivity`).
    stain_scale : (2,) median amount of each stain where it dominates; amounts are divided by it
        so that the red share of a pixel half muscle, half collagen is 1/2.
    seams : (n, H, W) bool, the SMC pixels on a thin valley of the muscle feature (:func:`seam_mask`): where two
        touching cells meet across an endomysium narrower than the blur. Labels keep them as SMC (point counting
        is unchanged); the tracer cuts the cells apart along them.
    """

    labels: np.ndarray
    method: str
    thresholds: dict[str, float]
    stains: np.ndarray | None = None
    spread: dict[str, float] = field(default_factory=dict)
    stain_scale: np.ndarray | None = None
    seams: np.ndarray | None = None


def check_rgb_stack(images) -> np.ndarray:
    """Return ``images`` as an (n, H, W, 3) array; raise for grayscale or malformed stacks."""
    a = np.asarray(images)
    if a.ndim == 3 and a.shape[-1] in (3, 4):
        a = a[None]
    if a.ndim == 3 or (a.ndim == 4 and a.shape[-1] not in (3, 4)):
        raise ValidationError(
            "images",
            f"shape {a.shape} (grayscale?)",
            "RGB micrographs of shape (n, H, W, 3)",
            "colour segmentation needs the stain colours; load the colour images",
        )
    if a.ndim != 4 or a.shape[0] == 0:
        raise ValidationError("images", f"shape {a.shape}", "a stack of shape (n, H, W, 3)")
    return a[..., :3]


def _as_unit_float(images: np.ndarray) -> np.ndarray:
    a = np.asarray(images)
    if a.dtype == np.uint8:
        return a.astype(float) / 255.0
    a = a.astype(float)
    return a / 255.0 if a.max() > 1.0 else a


def optical_density(images) -> np.ndarray:
    r"""Optical density :math:`-\ln((I + 1) / 256)` of 8-bit RGB (float images are scaled first)."""
    a = _as_unit_float(images)
    return -np.log((a * 255.0 + 1.0) / 256.0)


def estimate_stain_vectors(
    images, *, background_od: float = 0.3, percentile: float = 1.0, max_pixels: int = 200_000, rng=0
) -> np.ndarray:
    r"""Measure the two stain OD vectors from the images (Macenko et al. 2009).

    Tissue pixels (OD norm above ``background_od``) are projected on the plane of the two leading
    right singular vectors of their OD; the directions at the ``percentile`` and
    ``100 - percentile`` angles in that plane are the stains. The red stain (acid fuchsin, SMC)
    absorbs green most, the blue one (aniline blue, ECM) red most: the vector with the larger red
    OD share is the blue stain.

    Returns
    -------
    (2, 3) ndarray: unit OD vectors, row 0 the red (SMC) stain, row 1 the blue (ECM) stain.
    """
    rng = np.random.default_rng(rng)
    check_interval("percentile", percentile, 0.0, 50.0, closed=(True, False))
    rgb = check_rgb_stack(images).reshape(-1, 3)
    if len(rgb) > 20 * max_pixels:  # a uniform subsample first: no float copy of the whole stack
        rgb = rgb[rng.choice(len(rgb), 20 * max_pixels, replace=False)]
    od = optical_density(rgb)
    od = od[np.linalg.norm(od, axis=1) > background_od]
    if len(od) < 10:
        raise ValidationError("images", f"{len(od)} stained pixels", "stained tissue (OD norm > background_od)")
    if len(od) > max_pixels:
        od = od[rng.choice(len(od), max_pixels, replace=False)]
    _, _, vt = np.linalg.svd(od, full_matrices=False)
    plane = vt[:2]
    plane[0] *= np.sign(plane[0].sum()) or 1.0
    proj = od @ plane.T
    phi = np.arctan2(proj[:, 1], proj[:, 0])
    lo, hi = np.percentile(phi, [percentile, 100 - percentile])
    v = np.array([np.cos(lo) * plane[0] + np.sin(lo) * plane[1],
                  np.cos(hi) * plane[0] + np.sin(hi) * plane[1]])  # fmt: skip
    v *= np.sign(v.sum(axis=1, keepdims=True))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    red_share = v[:, 0] / v.sum(axis=1)
    return v[np.argsort(red_share)]  # smallest red-channel share first: the red stain


def _features(images, method, stains, scale=None):
    """Per-pixel (tissue, smc) features, float32 ``(n, H, W)`` each, computed section by section: the two stain
    amounts are recomputed per section in each pass instead of being held for the whole stack (they would take
    twice the memory of one feature); ``scale`` = typical amount of each pure stain."""
    shape = images.shape[:3]
    f_t = np.empty(shape, dtype=np.float32)
    if method == "deconvolution":
        unmix = np.linalg.pinv(stains)

        def amounts(section):  # (H, W, 2) float32 stain amounts
            return np.clip(optical_density(section) @ unmix, 0, None).astype(np.float32)

        for i, section in enumerate(images):
            f_t[i] = np.linalg.norm(optical_density(section), axis=-1)
        if scale is None:  # typical pure-stain amounts, from clearly stained pixels
            t = threshold_otsu(f_t) if np.ptp(f_t) > 0 else 0.0
            red_amounts, blue_amounts = [], []
            for i, section in enumerate(images):
                c = amounts(section)
                tissue = f_t[i] > t
                red = tissue & (c[..., 0] > c[..., 1])
                red_amounts.append(c[..., 0][red])
                blue_amounts.append(c[..., 1][tissue & ~red])
            scale = np.array([np.median(np.concatenate(v)) if sum(map(len, v)) else 1.0
                              for v in (red_amounts, blue_amounts)])  # fmt: skip
            del red_amounts, blue_amounts
            scale = np.where(scale > 0, scale, 1.0)
        share = np.empty(shape, dtype=np.float32)
        s32 = scale.astype(np.float32)
        for i, section in enumerate(images):
            c = amounts(section) / s32
            share[i] = c[..., 0] / np.maximum(c[..., 0] + c[..., 1], np.float32(1e-9))
        return f_t, share, scale
    hue = np.empty(shape, dtype=np.float32)
    for i, section in enumerate(images):
        lab = rgb2lab(_as_unit_float(section))
        f_t[i] = -lab[..., 0]  # -L so that "tissue" is above the threshold, as for OD
        hue[i] = np.degrees(np.arctan2(lab[..., 2], lab[..., 1]))
    return f_t, hue, None


def _classify(f_tissue, f_smc, t_tissue, t_smc):
    labels = np.full(f_tissue.shape, ECM, dtype=np.uint8)
    tissue = f_tissue > t_tissue
    labels[tissue & (f_smc > t_smc)] = SMC
    labels[~tissue] = CAVITY
    return labels


def segment_stack(
    images,
    *,
    method: str = "deconvolution",
    thresholds: dict[str, float] | None = None,
    stains=None,
    valid=None,
) -> Segmentation:
    """Segment RGB micrographs into CAVITY / ECM / SMC (module docstring).

    Parameters
    ----------
    images : (n, H, W, 3) RGB stack (uint8, or floats in [0, 1]).
    method : "deconvolution" (stain vectors measured from the images) or "lab".
    thresholds : optional fixed thresholds ``{"tissue": ..., "smc": ...}`` (deconvolution) or
        ``{"L": ..., "hue": ...}`` (Lab, L* in 0-100 and hue in degrees); default: Otsu on the
        stack.
    stains : optional (2, 3) OD vectors (red, blue); default: :func:`estimate_stain_vectors`.
    valid : optional (H, W) bool field used to choose the thresholds (e.g. the registered field).

    Returns
    -------
    Segmentation

    Raises
    ------
    ValidationError for grayscale input, an unknown method, or an empty segmentation (no tissue
    or no SMC pixel: check the stain and the thresholds).
    """
    if method not in _METHODS:
        raise ValidationError("method", method, f"one of {_METHODS}")
    imgs = check_rgb_stack(images)
    if method == "deconvolution":
        S = estimate_stain_vectors(imgs) if stains is None else np.asarray(stains, dtype=float)
        if S.shape != (2, 3):
            raise ValidationError("stains", f"shape {S.shape}", "(2, 3) OD vectors (red, blue)")
        names = ("tissue", "smc")
    else:
        S = None
        names = ("L", "hue")
    f_t, f_s, scale = _features(imgs, method, S)
    sel = np.ones(f_t.shape, dtype=bool)
    if valid is not None:
        sel = np.broadcast_to(np.asarray(valid, dtype=bool), f_t.shape)
        if not sel.any():
            raise ValidationError("valid", "an empty field", "a field with at least one pixel")
    if thresholds is None:
        t_t = float(threshold_otsu(f_t[sel]))
        tissue_sel = sel & (f_t > t_t)
        if not tissue_sel.any():
            raise ValidationError("segmentation", "no tissue pixel", "stained tissue in the images")
        t_s = float(threshold_otsu(f_s[tissue_sel])) if np.ptp(f_s[tissue_sel]) > 0 else 0.5
    else:
        missing = [k for k in names if k not in thresholds]
        if missing:
            raise ValidationError("thresholds", thresholds, f"keys {names} for method {method!r}")
        t_t, t_s = float(thresholds[names[0]]), float(thresholds[names[1]])
        if method == "lab":
            t_t = -t_t  # the feature is -L*
    labels = _classify(f_t, f_s, t_t, t_s)
    n_smc = int((labels[np.broadcast_to(sel, labels.shape)] == SMC).sum())
    if n_smc == 0:
        raise ValidationError(
            "segmentation",
            "no SMC pixel",
            "at least one pixel classified as smooth muscle",
            f"thresholds {dict(zip(names, (t_t, t_s), strict=True))}; check the stain/thresholds",
        )
    spread = {}
    for name, f, t, m in ((names[0], f_t, t_t, sel), (names[1], f_s, t_s, sel & (f_t > t_t))):
        above, below = f[m & (f > t)], f[m & (f <= t)]
        spread[name] = float(np.median(above) - np.median(below)) if above.size and below.size else 0.0
    th = {names[0]: -t_t if method == "lab" else t_t, names[1]: t_s}
    seams = seam_mask(f_s, labels == SMC)
    return Segmentation(
        labels=labels, method=method, thresholds=th, stains=S, spread=spread, stain_scale=scale, seams=seams
    )


#: Valley depth of :func:`seam_mask`, in units of the feature's pixel noise sd.
SEAM_DEPTH_SD = 2.0


def seam_mask(feature, smc, *, depth_sd: float = SEAM_DEPTH_SD) -> np.ndarray:
    r"""SMC pixels on a thin valley of the muscle feature (red share or hue): lower than both neighbours along a row,
    a column or a diagonal by more than ``depth_sd`` times the pixel noise,

    .. math:: f(\mathbf x) < \min\{f(\mathbf x - \mathbf e), f(\mathbf x + \mathbf e)\} - k\,\sigma,
        \quad \mathbf e \in \{(1, 0), (0, 1), (1, 1), (1, -1)\},

    a one-pixel-wide black top-hat along four directions (Soille 2003, Morphological Image Analysis, Ch. 4). The
    noise :math:`\sigma = 1.4826\,\mathrm{MAD}(\Delta f) / \sqrt 2` is measured on the differences between
    horizontally adjacent SMC pixels (robust to the few edges among them). A collagen seam between two touching
    cells, narrower than the blur, leaves such a valley in a pixel the thresholds still call muscle.

    Parameters
    ----------
    feature : (n, H, W) float, larger = more muscle. smc : (n, H, W) bool, the pixels labelled SMC.
    depth_sd : the valley depth k in noise sds (2: chosen on phantoms, docs/verification.md).
    """
    f = np.asarray(feature, dtype=np.float32)
    # section by section: whole-stack temporaries of the differences and comparisons would each take a feature's size
    d = np.concatenate([(g[:, 1:] - g[:, :-1])[m[:, 1:] & m[:, :-1]] for g, m in zip(f, smc, strict=True)])
    if d.size < 2:
        return np.zeros(f.shape, dtype=bool)
    d -= np.median(d)
    sigma = 1.4826 * float(np.median(np.abs(d, out=d))) / np.sqrt(2.0)
    del d
    tau = np.float32(depth_sd * sigma)
    valley = np.zeros(f.shape, dtype=bool)
    H, W = f.shape[1:]
    for g, v in zip(f, valley, strict=True):
        c = g[1:-1, 1:-1]
        for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
            lo = g[1 - dy : H - 1 - dy, 1 - dx : W - 1 - dx]
            hi = g[1 + dy : H - 1 + dy, 1 + dx : W - 1 + dx]
            v[1:-1, 1:-1] |= c < np.minimum(lo, hi) - tau
    return valley & smc


def label_fractions(labels, *, valid=None) -> dict[str, float]:
    """Pixel fractions: ``cavity_total`` of all pixels, ``smc_tissue`` / ``ecm_tissue`` of tissue."""
    lab = np.asarray(labels)
    if valid is not None:
        lab = lab[np.broadcast_to(np.asarray(valid, dtype=bool), lab.shape)]
    n = np.bincount(lab.ravel(), minlength=3).astype(float)
    tissue = n[ECM] + n[SMC]
    return {
        "cavity_total": n[CAVITY] / max(n.sum(), 1.0),
        "smc_tissue": n[SMC] / tissue if tissue else float("nan"),
        "ecm_tissue": n[ECM] / tissue if tissue else float("nan"),
    }


def threshold_sensitivity(
    images, segmentation: Segmentation, *, rel_shifts=(-0.2, -0.1, 0.1, 0.2), valid=None
) -> list[dict]:
    """Volume fractions after moving each threshold by ``rel_shift`` x its class-median gap.

    Parameters
    ----------
    images : the RGB stack that was segmented; segmentation : its :class:`Segmentation`.
    rel_shifts : threshold moves in units of ``segmentation.spread[name]``.
    valid : optional (H, W) field to count.

    Returns
    -------
    list of dicts ``threshold, rel_shift, value, cavity_total, smc_tissue, ecm_tissue``; the first
    row (``threshold = "none"``) is the unperturbed segmentation.
    """
    imgs = check_rgb_stack(images)
    base = dict(segmentation.thresholds)
    rows = [{"threshold": "none", "rel_shift": 0.0, "value": float("nan")}]
    rows[0].update(label_fractions(segmentation.labels, valid=valid))
    f_t, f_s, _ = _features(imgs, segmentation.method, segmentation.stains, segmentation.stain_scale)
    names = list(base)
    for name in names:
        for r in rel_shifts:
            th = dict(base)
            th[name] = base[name] + r * segmentation.spread.get(name, 0.0) * (
                -1 if (segmentation.method == "lab" and name == "L") else 1
            )
            t_t = -th[names[0]] if segmentation.method == "lab" else th[names[0]]
            lab = _classify(f_t, f_s, t_t, th[names[1]])
            row = {"threshold": name, "rel_shift": float(r), "value": float(th[name])}
            row.update(label_fractions(lab, valid=valid))
            rows.append(row)
    return rows


def confusion_matrix(labels, truth, *, valid=None) -> np.ndarray:
    """(3, 3) pixel counts, row = true class, column = assigned class (CAVITY, ECM, SMC)."""
    a, t = np.asarray(labels), np.asarray(truth)
    if a.shape != t.shape:
        raise ValidationError("truth", f"shape {t.shape}", f"the labels' shape {a.shape}")
    if valid is not None:
        m = np.broadcast_to(np.asarray(valid, dtype=bool), a.shape)
        a, t = a[m], t[m]
    return np.bincount(t.ravel().astype(int) * 3 + a.ravel(), minlength=9).reshape(3, 3)
