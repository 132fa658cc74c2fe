"""Rigid registration of serial micrographs.

Rotation from the log-polar FFT magnitude, translation by phase correlation, a local refinement of
the angle, and the chain of consecutive pairs composed into one frame.

Transforms are 3 x 3 homogeneous matrices on pixel coordinates ``(x, y) = (column, row)``. A
transform ``T_i`` of a stack maps reference (section 0) coordinates to the coordinates where the
same tissue appears in section ``i``, so the registered section is ``R_i(p) = I_i(T_i(p))`` (skimage
``warp(I_i, T_i)``).

References: Reddy & Chatterji 1996, IEEE Trans. Image Process. 5:1266, doi:10.1109/83.506761
(rotation from the log-polar Fourier magnitude); Guizar-Sicairos, Thurman & Fienup 2008, Opt. Lett.
33:156, doi:10.1364/OL.33.000156 (sub-pixel phase correlation, skimage ``phase_cross_correlation``).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, optimize
from skimage.color import rgb2gray
from skimage.filters import difference_of_gaussians, window
from skimage.registration import phase_cross_correlation
from skimage.transform import EuclideanTransform, warp, warp_polar

from bayestissue._validation import ValidationError, check_positive
from bayestissue.stereology.micrographs.render import rigid_matrix

__all__ = [
    "RegisteredStack",
    "estimate_rotation_logpolar",
    "estimate_rigid",
    "register_stack",
    "apply_transforms",
    "displacement_error_px",
    "rigid_params",
]


@dataclass
class RegisteredStack:
    """Result of :func:`register_stack`.

    Attributes
    ----------
    images : (n, H, W, ...) registered images (the input's type: 8-bit stays 8-bit, rounded; float input gives
        float64), NaN-free (edges extended).
    transforms : (n, 3, 3) reference -> section matrices; pairwise : (n - 1, 3) consecutive
        estimates
        (angle_deg, tx_px, ty_px) of section i+1 relative to section i.
    valid : (H, W) bool, reference pixels seen by every section (the common field to analyse).
    """

    images: np.ndarray
    transforms: np.ndarray
    pairwise: np.ndarray
    valid: np.ndarray


def _gray(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image, dtype=float)
    if img.ndim == 3:
        if img.shape[-1] not in (3, 4):
            raise ValidationError("image", f"shape {img.shape}", "a 2-D grayscale or (H, W, 3) RGB image")
        img = rgb2gray(img[..., :3] / (255.0 if img.max() > 1.0 else 1.0))
    elif img.ndim != 2:
        raise ValidationError("image", f"shape {img.shape}", "a 2-D grayscale or (H, W, 3) RGB image")
    return img


def estimate_rotation_logpolar(fixed, moving, *, upsample_factor: int = 20) -> float:
    r"""Rotation angle (degrees) of ``moving`` relative to ``fixed`` from their Fourier magnitudes.

    The magnitude of the Fourier transform ignores translation and rotates with the image; in polar
    coordinates :math:`(\log r, \theta)` the rotation becomes a shift along :math:`\theta`, found by
    phase correlation (Reddy & Chatterji 1996). The images are band-passed (difference of Gaussians,
    1-8 px) and Hann-windowed first. The angle is defined modulo 180 degrees (the magnitude is
    centro-symmetric) and returned in (-90, 90]; the sign convention is that of
    :func:`estimate_rigid` (positive: ``moving`` is ``fixed`` turned by +angle in (x, y) = (column,
    row) coordinates).
    """
    f, m = _gray(fixed), _gray(moving)
    if f.shape != m.shape:
        raise ValidationError("moving", f"shape {m.shape}", f"the shape of fixed, {f.shape}")
    win = window("hann", f.shape)
    spectra = []
    for img in (f, m):
        band = difference_of_gaussians(img - img.mean(), 1, 8) * win
        spectra.append(np.abs(np.fft.fftshift(np.fft.fft2(band))))
    radius = min(f.shape) // 2
    shape = (360, radius)
    polar = [warp_polar(s, radius=radius, output_shape=shape, scaling="log", order=1) for s in spectra]
    polar = [p[:180] for p in polar]  # half turn: the magnitude is centro-symmetric
    shift, _, _ = phase_cross_correlation(polar[0], polar[1], upsample_factor=upsample_factor, normalization=None)
    angle = -float(shift[0])  # one row = one degree
    angle = (angle + 90.0) % 180.0 - 90.0
    return angle


def _translation(fixed, moving_aligned, upsample_factor):
    shift, _, _ = phase_cross_correlation(fixed, moving_aligned, upsample_factor=upsample_factor, normalization=None)
    return shift  # (dy, dx): moving_aligned shifted by it matches fixed


def _ncc(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    return float((a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum() + 1e-300))


def _coarse(fixed, moving, angle_deg, upsample_factor, centre, inner):
    """Best transform at a fixed angle (translation by phase correlation) and its NCC."""
    rot = rigid_matrix(angle_deg, 0.0, 0.0, centre)
    turned = warp(moving, EuclideanTransform(matrix=rot), order=1, mode="edge")
    dy, dx = _translation(fixed, turned, upsample_factor)
    # turned(p) = moving(rot p); shifted(p) = turned(p - d) = moving(rot (p - d))
    M = rot @ rigid_matrix(0.0, -dx, -dy, centre)
    aligned = warp(moving, EuclideanTransform(matrix=M), order=1, mode="edge")
    return _ncc(fixed[inner], aligned[inner]), M


def estimate_rigid(
    fixed,
    moving,
    *,
    max_rotation_deg: float = 6.0,
    angle_step_deg: float = 1.0,
    smooth_px: float = 1.0,
    upsample_factor: int = 20,
) -> np.ndarray:
    r"""Rigid transform ``A`` (3 x 3, on (x, y) pixel coordinates) with ``moving(A q) ~ fixed(q)``.

    1. Both images are turned to gray, smoothed (Gaussian, ``smooth_px``) and centred.
    2. Coarse search: for each trial angle (a grid of step ``angle_step_deg`` over
       +-``max_rotation_deg`` plus the log-polar Fourier estimate of
       :func:`estimate_rotation_logpolar`) the moving image is turned back and the translation
       found by sub-pixel phase correlation (``upsample_factor``, Guizar-Sicairos et al. 2008).
    3. The best trial is refined in (angle, tx, ty) by maximising the normalised
       cross-correlation (NCC) of the aligned images on the central field (Nelder-Mead).

    Parameters
    ----------
    fixed, moving : 2-D grayscale or (H, W, 3) RGB images of the same shape.

    Returns
    -------
    (3, 3) ndarray: :math:`A(\mathbf q) = R(\theta)(\mathbf q - \mathbf c) + \mathbf c +
    \mathbf t`, :math:`\mathbf c` the image centre.
    """
    f, m = _gray(fixed), _gray(moving)
    if f.shape != m.shape:
        raise ValidationError("moving", f"shape {m.shape}", f"the shape of fixed, {f.shape}")
    max_rotation_deg = check_positive("max_rotation_deg", max_rotation_deg, allow_zero=True)
    angle_step_deg = check_positive("angle_step_deg", angle_step_deg)
    smooth_px = check_positive("smooth_px", smooth_px, allow_zero=True)
    if smooth_px > 0:
        f, m = ndimage.gaussian_filter(f, smooth_px), ndimage.gaussian_filter(m, smooth_px)
    f, m = f - f.mean(), m - m.mean()
    for name, img in (("fixed", f), ("moving", m)):
        if not np.any(np.abs(img) > 1e-12):
            raise ValidationError(name, "a blank (uniform) image", "an image with structure")
    H, W = f.shape
    centre = ((W - 1) / 2, (H - 1) / 2)
    mh, mw = max(1, H // 8), max(1, W // 8)
    inner = (slice(mh, H - mh), slice(mw, W - mw))
    n_half = int(np.floor(max_rotation_deg / angle_step_deg))
    trials = list(np.arange(-n_half, n_half + 1) * angle_step_deg)
    lp = estimate_rotation_logpolar(f, m, upsample_factor=upsample_factor)
    if abs(lp) <= max_rotation_deg:
        trials.append(lp)
    scored = [_coarse(f, m, a, upsample_factor, centre, inner) for a in trials]
    best = max(range(len(scored)), key=lambda k: scored[k][0])
    x0 = rigid_params(scored[best][1], f.shape)

    def cost(x):
        M = rigid_matrix(x[0], x[1], x[2], centre)
        aligned = warp(m, EuclideanTransform(matrix=M), order=1, mode="edge")
        return -_ncc(f[inner], aligned[inner])

    simplex = x0 + np.array([[0, 0, 0], [0.5, 0, 0], [0, 0.5, 0], [0, 0, 0.5]])
    res = optimize.minimize(
        cost,
        x0,
        method="Nelder-Mead",
        options={"initial_simplex": simplex, "xatol": 0.005, "fatol": 1e-7, "maxiter": 400},
    )
    x = res.x if res.fun <= cost(x0) else x0
    return rigid_matrix(x[0], x[1], x[2], centre)


def apply_transforms(images: np.ndarray, transforms: np.ndarray, *, order: int = 1) -> np.ndarray:
    """Warp every section into the reference frame: ``R_i(p) = I_i(T_i p)`` (edges extended).

    The result keeps an integer input's type (8-bit sections stay 8-bit: the interpolated values are rounded, an
    error of at most half a grey level, where a float64 copy would take 8 times the stack's memory); float input
    gives float64."""
    images = np.asarray(images)
    integer = np.issubdtype(images.dtype, np.integer)
    out = np.empty(images.shape, dtype=images.dtype if integer else float)
    top = np.iinfo(images.dtype).max if integer else None
    for i, (img, T) in enumerate(zip(images, transforms, strict=True)):
        w = warp(
            np.asarray(img, dtype=float),
            EuclideanTransform(matrix=T),
            order=order,
            mode="edge",
            preserve_range=True,
        )
        out[i] = np.clip(np.rint(w), 0, top) if integer else w
    return out


def register_stack(
    images: np.ndarray,
    *,
    max_rotation_deg: float = 6.0,
    upsample_factor: int = 20,
    n_template: int = 3,
    progress: Callable[[int], None] | None = None,
) -> RegisteredStack:
    r"""Register a stack of serial sections to its first section.

    Section *i* is registered to a template, the mean of the previous ``n_template`` sections
    already brought into the reference frame, which gives :math:`T_i` directly. Averaging
    neighbours keeps the common structure and damps the section-to-section changes that make a
    chain of single pairs (``n_template = 1``: :math:`T_i = A_{i-1,i} T_{i-1}`) drift like a
    random walk. The valid field is where every section has data.

    Parameters
    ----------
    images : (n, H, W, 3) RGB or (n, H, W) grayscale stack, all sections the same size.
    n_template : number of previous registered sections averaged into the template.
    progress : optional callable called with 1 after each section (e.g. ``tqdm.update``).

    Returns
    -------
    RegisteredStack
    """
    images = np.asarray(images)
    if images.ndim not in (3, 4) or images.shape[0] < 1:
        raise ValidationError("images", f"shape {images.shape}", "a stack (n, H, W) or (n, H, W, 3)")
    if int(n_template) != n_template or n_template < 1:
        raise ValidationError("n_template", n_template, "a positive integer")
    n = images.shape[0]
    T = np.empty((n, 3, 3))
    T[0] = np.eye(3)
    # gray sections are made one at a time and only the last n_template registered ones are kept: a float64 gray
    # copy of the whole stack would be 8 / 3 of an RGB uint8 stack's memory, and the registered copies as much again
    previous = _gray(images[0])
    registered = deque([previous], maxlen=int(n_template))
    pairwise = np.empty((max(n - 1, 0), 3))
    for i in range(1, n):
        current = _gray(images[i])
        if n_template == 1:
            A = estimate_rigid(previous, current, max_rotation_deg=max_rotation_deg, upsample_factor=upsample_factor)
            T[i] = A @ T[i - 1]
        else:
            template = np.mean(registered, axis=0)
            T[i] = estimate_rigid(template, current, max_rotation_deg=max_rotation_deg, upsample_factor=upsample_factor)
            registered.append(warp(current, EuclideanTransform(matrix=T[i]), order=1, mode="edge"))
        pairwise[i - 1] = rigid_params(T[i] @ np.linalg.inv(T[i - 1]), current.shape)
        previous = current
        if progress is not None:
            progress(1)
    H, W = images.shape[1:3]
    yy, xx = np.mgrid[0:H, 0:W]
    pts = np.stack([xx.ravel(), yy.ravel(), np.ones(xx.size)])
    valid = np.ones(H * W, dtype=bool)
    for Ti in T:
        q = Ti @ pts
        valid &= (q[0] >= 0) & (q[0] <= W - 1) & (q[1] >= 0) & (q[1] <= H - 1)
    reg = apply_transforms(images, T)
    return RegisteredStack(images=reg, transforms=T, pairwise=pairwise, valid=valid.reshape(H, W))


def rigid_params(A: np.ndarray, shape) -> np.ndarray:
    """(angle_deg, tx, ty) of a rigid matrix about the centre of an image of ``shape``."""
    H, W = shape[:2]
    c = np.array([(W - 1) / 2, (H - 1) / 2])
    angle = np.rad2deg(np.arctan2(A[1, 0], A[0, 0]))
    t = A[:2, 2] - (c - A[:2, :2] @ c)
    return np.array([angle, t[0], t[1]])


def displacement_error_px(estimated: np.ndarray, true: np.ndarray, shape, *, mask=None) -> np.ndarray:
    r"""Mean displacement (px) between estimated and true transforms over an image field.

    .. math:: e_i = \operatorname{mean}_{\mathbf p} \lVert \hat T_i \mathbf p - T_i \mathbf p \rVert

    Parameters
    ----------
    estimated, true : (n, 3, 3) matrices, or (n, 3) rows (angle_deg, tx_px, ty_px) about the image
        centre.
    mask : optional (H, W) bool field to average over.

    Returns
    -------
    (n,) ndarray of mean errors in pixels.
    """
    H, W = shape[:2]
    c = ((W - 1) / 2, (H - 1) / 2)

    def _mats(x):
        x = np.asarray(x, dtype=float)
        if x.ndim == 2 and x.shape[1] == 3:
            return np.array([rigid_matrix(*r, c) for r in x])
        return x

    E, Tt = _mats(estimated), _mats(true)
    yy, xx = np.mgrid[0:H, 0:W]
    sel = np.ones((H, W), dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
    pts = np.stack([xx[sel], yy[sel], np.ones(sel.sum())])
    return np.array([np.linalg.norm((e @ pts - t @ pts)[:2], axis=0).mean() for e, t in zip(E, Tt, strict=True)])
