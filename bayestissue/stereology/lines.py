r"""Line systems approximating the axes of traced cells, their length density and directions.

The paper (Section 2.5.2-2.5.3) traced the centres of gravity of the smooth muscle cells through a
stack of ten registered micrographs and approximated them by lines; the length density is eq. (2),

.. math:: L_V(\text{SMC}, \text{ref}) = L(\text{SMC}) / V(\text{ref}),

3171.1 um / 184 774 um^3 = 0.0172 um^-2 in the paper.

Frame and angles (the project's body frame, docs/model.md): x the loading direction (longitudinal), y
top-down, z the remaining axis. Lines are axes, mapped to the upper hemisphere :math:`z \ge 0` with
the pole on z; azimuth :math:`\varphi = \operatorname{atan2}(y, x) \in [0, 360)` degrees and
elevation :math:`\epsilon = \arcsin z \in [0, 90]` degrees (the angle above the x-y plane). The
paper's three fibre directions all have z = 0, i.e. elevation 0 ("elevations near zero"). On the
equator (z = 0 exactly) the representative is the one with y > 0, or x > 0 when y = 0 too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError, check_positive

__all__ = [
    "LineSystem",
    "segments_from_polylines",
    "length_density",
    "stack_volume",
    "to_upper_hemisphere",
    "azimuth_elevation",
    "unit_vector",
]


def to_upper_hemisphere(d) -> np.ndarray:
    """Normalise axes and flip them to z >= 0 (ties on the equator: y > 0, then x > 0)."""
    d = np.asarray(d, dtype=float)
    n = np.linalg.norm(d, axis=-1, keepdims=True)
    if np.any(n == 0) or not np.all(np.isfinite(d)):
        raise ValidationError("directions", "a zero or non-finite vector", "non-zero finite directions")
    d = d / n
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    flip = (z < 0) | ((z == 0) & ((y < 0) | ((y == 0) & (x < 0))))
    return np.where(flip[..., None], -d, d)


def azimuth_elevation(d) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth atan2(y, x) in [0, 360) and elevation arcsin(z) in [0, 90] degrees of axes (upper
    hemisphere)."""
    u = to_upper_hemisphere(d)
    az = np.degrees(np.arctan2(u[..., 1], u[..., 0])) % 360.0
    el = np.degrees(np.arcsin(np.clip(u[..., 2], -1.0, 1.0)))
    return az, el


def unit_vector(azimuth_deg, elevation_deg) -> np.ndarray:
    """Unit vector(s) (cos el cos az, cos el sin az, sin el) from angles in degrees."""
    a = np.radians(np.asarray(azimuth_deg, dtype=float))
    e = np.radians(np.asarray(elevation_deg, dtype=float))
    return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1)


def length_density(total_length_um: float, volume_um3: float) -> float:
    r"""Length density :math:`L_V = L / V` in um^-2 (paper eq. 2)."""
    L = check_positive("total_length_um", total_length_um, allow_zero=True)
    V = check_positive("volume_um3", volume_um3)
    return L / V


def stack_volume(extent_x_um: float, extent_y_um: float, n_sections: int, thickness_um: float) -> float:
    """Probed volume of a stack of ``n_sections`` sections of ``thickness_um`` over an image of the
    given extent."""
    if isinstance(n_sections, bool) or not float(n_sections).is_integer() or int(n_sections) < 1:
        raise ValidationError("n_sections", n_sections, "an integer >= 1")
    return (
        check_positive("extent_x_um", extent_x_um)
        * check_positive("extent_y_um", extent_y_um)
        * int(n_sections)
        * check_positive("thickness_um", thickness_um)
    )


def segments_from_polylines(polylines, cell_ids) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split polylines (one (k_i, 3) vertex array per traced cell, k_i >= 2) into segments.

    Returns ``start`` (n, 3), ``end`` (n, 3) and ``cell`` (n,).
    """
    if len(polylines) != len(cell_ids):
        raise ValidationError("cell_ids", len(cell_ids), f"{len(polylines)} ids, one per polyline")
    s, e, c = [], [], []
    for pts, cid in zip(polylines, cell_ids, strict=True):
        p = np.asarray(pts, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 2:
            raise ValidationError(f"polyline of cell {cid}", f"shape {p.shape}", "(k >= 2, 3) vertices")
        s.append(p[:-1])
        e.append(p[1:])
        c.extend([cid] * (len(p) - 1))
    return np.concatenate(s), np.concatenate(e), np.asarray(c)


@dataclass(frozen=True)
class LineSystem:
    """Straight segments (um) of traced cells, with the probed volume.

    Parameters
    ----------
    start, end : (n, 3) segment end points in um, body frame (x, y, z).
    cell : (n,) id of the traced cell each segment belongs to (the unit of the bootstrap).
    volume_um3 : probed volume of the stack, for L_V; None if unknown.
    """

    start: np.ndarray
    end: np.ndarray
    cell: np.ndarray
    volume_um3: float | None = None

    def __post_init__(self):
        s = np.asarray(self.start, dtype=float)
        e = np.asarray(self.end, dtype=float)
        c = np.asarray(self.cell)
        if s.ndim != 2 or s.shape[1] != 3 or s.shape != e.shape or s.shape[0] == 0:
            raise ValidationError("start/end", f"shapes {s.shape}, {e.shape}", "equal (n >= 1, 3) arrays")
        if c.shape != (s.shape[0],):
            raise ValidationError("cell", f"shape {c.shape}", f"({s.shape[0]},) one id per segment")
        if not (np.all(np.isfinite(s)) and np.all(np.isfinite(e))):
            raise ValidationError("start/end", "non-finite coordinates", "finite coordinates in um")
        length = np.linalg.norm(e - s, axis=1)
        zero = np.flatnonzero(length <= 0)
        if zero.size:
            raise ValidationError(
                "segment",
                f"row {zero[0]} (cell {c[zero[0]]}) of length 0",
                "segments of positive length",
            )
        if self.volume_um3 is not None:
            check_positive("volume_um3", self.volume_um3)
        object.__setattr__(self, "start", s)
        object.__setattr__(self, "end", e)
        object.__setattr__(self, "cell", c)

    @classmethod
    def from_file(cls, path) -> LineSystem:
        """Read a line-system table and its sidecar (:func:`bayestissue.io.stereology_files.read_line_system`)."""
        from bayestissue.io.stereology_files import read_line_system

        d = read_line_system(path)
        return cls(d["start"], d["end"], d["cell"], d["volume_um3"])

    @property
    def lengths(self) -> np.ndarray:
        """(n,) segment lengths in um."""
        return np.linalg.norm(self.end - self.start, axis=1)

    @property
    def directions(self) -> np.ndarray:
        """(n, 3) unit axes on the upper hemisphere."""
        return to_upper_hemisphere(self.end - self.start)

    @property
    def total_length_um(self) -> float:
        """Total length L in um."""
        return float(self.lengths.sum())

    @property
    def n_cells(self) -> int:
        """Number of distinct traced cells."""
        return int(np.unique(self.cell).size)

    def length_density(self) -> float:
        """L_V = L / V in um^-2 (paper eq. 2); needs ``volume_um3``."""
        if self.volume_um3 is None:
            raise ValidationError("volume_um3", None, "the probed volume (sidecar) to compute L_V")
        return length_density(self.total_length_um, self.volume_um3)

    def subset(self, index) -> LineSystem:
        """Segments at ``index`` (repeats allowed, as in a bootstrap)."""
        i = np.asarray(index)
        return LineSystem(self.start[i], self.end[i], self.cell[i], self.volume_um3)
