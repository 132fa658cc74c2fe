"""Serial sections of a phantom rendered as misregistered Mallory-trichrome micrographs.

Each section is the mid-plane of a slab of thickness ``thickness_um`` cut perpendicular to the
chosen axis. Its colour follows Beer-Lambert absorption of two stains (acid fuchsin staining the
muscle red, aniline blue the collagen), so that colour deconvolution is the matching inverse model:

.. math:: I_c(\\mathbf p) = \\exp\\bigl(-\\sum_s c_s(\\mathbf p)\\, \\mathrm{OD}_{s,c} -
\\mathrm{OD}_{0,c}\\bigr),
          \\qquad \\mathrm{OD}_{s,c} = -\\ln \\mathrm{RGB}_{s,c},

where the stain amounts :math:`c_s` are 1 on their component times a section factor (log-normal,
section-to-section stain variability) times a smooth spatial texture. The image is then blurred
(Gaussian point-spread function), moved by a rigid misregistration (rotation about the field centre,
then a shift), cropped to the camera field and given Gaussian noise (Ruifrok & Johnston 2001, Anal.
Quant. Cytol. Histol. 23:291 for the stain model).

Section 0 is the reference: its transform is the identity. Transforms map reference-field pixel
coordinates ``(x, y) = (column, row)`` to the pixel where the same tissue point appears in section
``i``:

.. math:: A_i(\\mathbf q) = R(\\theta_i)(\\mathbf q - \\mathbf c) + \\mathbf c + \\mathbf t_i .
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from skimage.transform import EuclideanTransform, warp

from bayestissue._validation import ValidationError, check_interval, check_positive
from bayestissue.stereology.micrographs.phantom import ECM, SMC, TissuePhantom

__all__ = [
    "StainOptions",
    "RenderedStack",
    "section_phantom",
    "render_sections",
    "rigid_matrix",
    "stack_frame",
]

_AXES = {"z": 0, "y": 1, "x": 2}


@dataclass(frozen=True)
class StainOptions:
    """Appearance of the rendered micrographs.

    Parameters
    ----------
    smc_rgb, ecm_rgb : transmitted colour of fully stained muscle (red) and collagen (blue), in (0,
        1].
    background_rgb : colour of empty glass (cavities).
    stain_cv : log-normal sd of each stain's amount from section to section.
    texture_sd, texture_scale_px : relative sd and correlation length of the within-section stain
        texture.
    blur_px : sd of the Gaussian point-spread function in pixels.
    noise_sd : sd of additive Gaussian noise on intensities in [0, 1].
    shift_sd_px, rotation_sd_deg : sd of the per-section misregistration (truncated at 2.5 sd).
    """

    smc_rgb: tuple[float, float, float] = (0.80, 0.28, 0.34)
    ecm_rgb: tuple[float, float, float] = (0.38, 0.50, 0.86)
    background_rgb: tuple[float, float, float] = (0.96, 0.96, 0.95)
    stain_cv: float = 0.10
    texture_sd: float = 0.12
    texture_scale_px: float = 1.5
    blur_px: float = 0.8
    noise_sd: float = 0.02
    shift_sd_px: float = 2.0
    rotation_sd_deg: float = 1.5

    def __post_init__(self):
        for name in ("smc_rgb", "ecm_rgb", "background_rgb"):
            c = np.asarray(getattr(self, name), dtype=float)
            if c.shape != (3,) or np.any(~np.isfinite(c)) or np.any(c <= 0) or np.any(c > 1):
                raise ValidationError(name, getattr(self, name), "three intensities in (0, 1]")
        for name in (
            "stain_cv",
            "texture_sd",
            "blur_px",
            "noise_sd",
            "shift_sd_px",
            "rotation_sd_deg",
        ):
            check_positive(name, getattr(self, name), allow_zero=True)
        check_positive("texture_scale_px", self.texture_scale_px)
        check_interval("rotation_sd_deg", self.rotation_sd_deg, 0.0, 10.0)


@dataclass
class RenderedStack:
    """Rendered serial micrographs and their truth.

    Attributes
    ----------
    images : (n, H, W, 3) uint8 RGB micrographs.
    labels : (n, H, W) uint8 true components (CAVITY/ECM/SMC) in each image's own (misregistered)
        frame.
    transforms : (n, 3) ndarray of (angle_deg, tx_px, ty_px): reference field -> section i (module
        docstring).
    pixel_um, thickness_um : pixel size and section thickness in um.
    section_axis : the phantom axis the sections are perpendicular to ('z', 'y' or 'x').
    margin_px : crop margin of the camera field inside the phantom's section plane.
    plane_index : (n,) index of each section's mid-plane along the section axis (phantom voxels).
    stain_factors : (n, 2) section factors of the red and the blue stain.
    """

    images: np.ndarray
    labels: np.ndarray
    transforms: np.ndarray
    pixel_um: float
    thickness_um: float
    section_axis: str
    margin_px: int
    plane_index: np.ndarray
    stain_factors: np.ndarray

    def truth(self) -> dict:
        """Misregistration truth as a JSON-serialisable dict (consecutive differences included)."""
        t = self.transforms
        return {
            "pixel_um": self.pixel_um,
            "section_thickness_um": self.thickness_um,
            "section_axis": self.section_axis,
            "margin_px": self.margin_px,
            "image_shape_hw": list(self.images.shape[1:3]),
            "plane_index": self.plane_index.tolist(),
            "transforms_ref_to_section": [
                {"angle_deg": float(a), "tx_px": float(x), "ty_px": float(y)} for a, x, y in t
            ],
            "consecutive_misregistration": [
                {"angle_deg": float(a), "tx_px": float(x), "ty_px": float(y)} for a, x, y in np.diff(t, axis=0)
            ],
            "stain_factors_red_blue": self.stain_factors.round(5).tolist(),
        }


def rigid_matrix(angle_deg: float, tx: float, ty: float, centre) -> np.ndarray:
    """3 x 3 matrix of ``q -> R(angle)(q - centre) + centre + t`` on (x, y) pixel coordinates."""
    th = np.deg2rad(angle_deg)
    c, s = np.cos(th), np.sin(th)
    R = np.array([[c, -s], [s, c]])
    cx = np.asarray(centre, dtype=float)
    M = np.eye(3)
    M[:2, :2] = R
    M[:2, 2] = cx - R @ cx + np.array([tx, ty])
    return M


def stack_frame(axis: str = "z") -> np.ndarray:
    """Rows: the phantom (x, y, z) unit vectors of the stack's x (columns), y (rows) and z
    (section index) axes, so that ``v_stack = stack_frame(axis) @ v_phantom``."""
    if axis not in _AXES:
        raise ValidationError("section_axis", axis, "one of 'z', 'y', 'x'")
    e = np.eye(3)
    return {"z": e, "y": e[[0, 2, 1]], "x": e[[1, 2, 0]]}[axis]


def section_phantom(
    phantom: TissuePhantom, *, thickness_um: float = 5.0, axis: str = "z"
) -> tuple[np.ndarray, np.ndarray]:
    """Mid-planes of consecutive slabs of thickness ``thickness_um`` perpendicular to ``axis``.

    Returns
    -------
    planes : (n, A, B) uint8 component planes; for ``axis='z'`` rows are y and columns x, for 'y'
        rows z and
        columns x, for 'x' rows z and columns y (the remaining axes in array order).
    plane_index : (n,) voxel index of each mid-plane along ``axis``.
    """
    if axis not in _AXES:
        raise ValidationError("section_axis", axis, "one of 'z', 'y', 'x'")
    thickness_um = check_positive("thickness_um", thickness_um)
    k = _AXES[axis]
    depth = phantom.components.shape[k] * phantom.voxel_um
    n = int(np.floor(depth / thickness_um + 1e-9))
    if n < 1 or thickness_um < phantom.voxel_um:
        raise ValidationError(
            "thickness_um",
            thickness_um,
            f"between the voxel size {phantom.voxel_um} um and the block depth {depth} um",
        )
    idx = np.floor(((np.arange(n) + 0.5) * thickness_um) / phantom.voxel_um).astype(int)
    planes = np.moveaxis(phantom.components, k, 0)[idx]
    return np.ascontiguousarray(planes), idx


def render_sections(
    phantom: TissuePhantom,
    *,
    thickness_um: float = 5.0,
    axis: str = "z",
    stain: StainOptions | None = None,
    margin_px: int | None = None,
    rng=None,
) -> RenderedStack:
    """Render the serial sections of ``phantom`` as misregistered Mallory-trichrome micrographs.

    Parameters
    ----------
    phantom : the tissue block.
    thickness_um : section thickness (paper: 5 um).
    axis : phantom axis perpendicular to the sections.
    stain : StainOptions (colours, variability, blur, noise, misregistration sizes).
    margin_px : crop margin around the camera field; default: enough for the largest allowed
        misregistration.
    rng : seed or Generator (same seed, same images).

    Returns
    -------
    RenderedStack
    """
    rng = np.random.default_rng(rng)
    st = stain if stain is not None else StainOptions()
    planes, idx = section_phantom(phantom, thickness_um=thickness_um, axis=axis)
    n, A, B = planes.shape
    max_shift = 2.5 * st.shift_sd_px
    max_rot = 2.5 * st.rotation_sd_deg
    if margin_px is None:
        half_diag = 0.5 * np.hypot(A, B)
        margin_px = int(np.ceil(max_shift * np.sqrt(2) + half_diag * 2 * np.sin(np.deg2rad(max_rot) / 2)))
        margin_px += 1
    margin_px = int(margin_px)
    H, W = A - 2 * margin_px, B - 2 * margin_px
    if H < 8 or W < 8:
        raise ValidationError(
            "margin_px",
            margin_px,
            f"a margin leaving at least 8 x 8 pixels of the {A} x {B} section plane",
        )
    angles = np.clip(rng.normal(0, st.rotation_sd_deg, n), -max_rot, max_rot)
    shifts = np.clip(rng.normal(0, st.shift_sd_px, (n, 2)), -max_shift, max_shift)
    angles[0], shifts[0] = 0.0, 0.0
    transforms = np.column_stack([angles, shifts])
    factors = np.exp(rng.normal(0, st.stain_cv, (n, 2)))

    od = -np.log(np.array([st.smc_rgb, st.ecm_rgb, st.background_rgb], dtype=float))
    centre = ((W - 1) / 2, (H - 1) / 2)
    images = np.empty((n, H, W, 3), dtype=np.uint8)
    labels = np.empty((n, H, W), dtype=np.uint8)
    for i in range(n):
        plane = planes[i]
        tex = rng.standard_normal((2, A, B))
        tex = ndimage.gaussian_filter(tex, (0, st.texture_scale_px, st.texture_scale_px))
        tex *= st.texture_sd / max(tex.std(), 1e-12)
        c_red = (plane == SMC) * factors[i, 0] * (1 + tex[0])
        c_blue = (plane == ECM) * factors[i, 1] * (1 + tex[1])
        optical = c_red[..., None] * od[0] + c_blue[..., None] * od[1] + od[2]
        rgb = np.exp(-optical)
        if st.blur_px > 0:
            rgb = ndimage.gaussian_filter(rgb, (st.blur_px, st.blur_px, 0))
        # output pixel p (cropped field) -> reference field q = A_i^{-1}(p) -> plane pixel q +
        # margin
        inv = np.linalg.inv(rigid_matrix(*transforms[i], centre))
        shift = np.eye(3)
        shift[:2, 2] = margin_px
        tf = EuclideanTransform(matrix=shift @ inv)
        moved = warp(rgb, tf, output_shape=(H, W), order=1, mode="edge", preserve_range=True)
        lab = warp(plane, tf, output_shape=(H, W), order=0, mode="edge", preserve_range=True)
        moved = moved + rng.normal(0, st.noise_sd, moved.shape) if st.noise_sd > 0 else moved
        images[i] = np.round(np.clip(moved, 0, 1) * 255).astype(np.uint8)
        labels[i] = lab.astype(np.uint8)
    return RenderedStack(
        images=images,
        labels=labels,
        transforms=transforms,
        pixel_um=phantom.voxel_um,
        thickness_um=float(thickness_um),
        section_axis=axis,
        margin_px=margin_px,
        plane_index=idx,
        stain_factors=factors,
    )
