"""Point counts on serial sections: the data object of the volume-fraction estimators (:class:`PointCounts`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.stereology.sections import (
    DISC_SHAPE_FACTOR,
    _check_counts,
    ce_sum,
    classic_ratio_ce,
    fraction_covariance,
    nugget_variance,
    smoothness_q_hat,
)

__all__ = ["PointCounts"]


@dataclass(frozen=True)
class PointCounts:
    """Point counts per sampled section, one column per component.

    Parameters
    ----------
    section : (n,) int positions of the sections in the series.
    counts : (n, K) points hitting each component.
    components : K component names (e.g. ``("smc", "ecm", "other")``).
    excluded : names excluded from the reference space (cavities, "other").
    grid_spacing_um : optional point-grid spacing.
    block : optional (n,) labels of independent units (blocks, animals) for the cluster bootstrap.
    shape_factor : profile shape factor b / sqrt(a) for the nugget (default a disc, 3.545).
    profiles_per_section : profiles of each phase per section for the nugget (default 1: one profile per
        section, Gundersen et al. 1999); a fragmented meshwork has many.
    """

    section: np.ndarray
    counts: np.ndarray
    components: tuple[str, ...]
    excluded: tuple[str, ...] = ()
    grid_spacing_um: float | None = None
    block: np.ndarray | None = field(default=None)
    shape_factor: float = DISC_SHAPE_FACTOR
    profiles_per_section: float | None = None

    def __post_init__(self):
        counts = _check_counts("counts", self.counts)
        if counts.ndim != 2 or counts.shape[1] != len(self.components):
            raise ValidationError(
                "counts",
                f"shape {counts.shape}",
                f"(n_sections, {len(self.components)}) for {self.components}",
            )
        section = np.asarray(self.section)
        if section.shape != (counts.shape[0],):
            raise ValidationError("section", f"shape {section.shape}", f"({counts.shape[0]},)")
        if len(np.unique(section)) != section.size:
            raise ValidationError("section", section.tolist(), "distinct section positions")
        if len(set(self.components)) != len(self.components):
            raise ValidationError("components", self.components, "distinct names")
        for name in self.excluded:
            if name not in self.components:
                raise ValidationError("excluded", name, f"one of {list(self.components)}")
        if len(self.reference_components) == 0:
            raise ValidationError("excluded", self.excluded, "at least one component left in the reference")
        if self.grid_spacing_um is not None:
            check_positive("grid_spacing_um", self.grid_spacing_um)
        check_positive("shape_factor", self.shape_factor)
        if self.profiles_per_section is not None:
            check_positive("profiles_per_section", self.profiles_per_section)
        if self.block is not None and np.asarray(self.block).shape != section.shape:
            raise ValidationError("block", f"shape {np.asarray(self.block).shape}", f"{section.shape}")
        object.__setattr__(self, "counts", counts)
        object.__setattr__(self, "section", section)

    @classmethod
    def from_file(cls, path) -> PointCounts:
        """Read a point-count table (:func:`bayestissue.io.stereology_files.read_point_counts`)."""
        from bayestissue.io.stereology_files import read_point_counts

        d = read_point_counts(path)
        kw = {}
        if d["nugget_shape_factor"] is not None:
            kw["shape_factor"] = d["nugget_shape_factor"]
        if d["nugget_profiles_per_section"] is not None:
            kw["profiles_per_section"] = d["nugget_profiles_per_section"]
        try:
            return cls(
                d["section"],
                d["counts"],
                d["components"],
                d["excluded"],
                grid_spacing_um=d["grid_spacing_um"],
                block=d["block"],
                **kw,
            )
        except ValidationError as exc:
            raise exc.within(Path(path).name) from None

    @property
    def reference_components(self) -> tuple[str, ...]:
        """Components inside the reference space, in table order."""
        return tuple(c for c in self.components if c not in self.excluded)

    def column(self, name: str) -> np.ndarray:
        """Counts of one component (raises for an unknown name)."""
        if name not in self.components:
            raise ValidationError("component", name, f"one of {list(self.components)}")
        return self.counts[:, self.components.index(name)]

    def reference_counts(self) -> np.ndarray:
        """(n, K_ref) counts of the reference components, sections in increasing position."""
        order = np.argsort(self.section, kind="stable")
        return np.stack([self.column(c)[order] for c in self.reference_components], axis=1)

    def ce_kwargs(self) -> dict:
        """Nugget options for :func:`fraction_covariance` from ``shape_factor`` and
        ``profiles_per_section`` (profiles = per-section count times the non-empty sections)."""
        out = {"shape_factors": self.shape_factor}
        if self.profiles_per_section is not None:
            Q = self.reference_counts()
            X = np.concatenate([Q, Q.sum(axis=1, keepdims=True)], axis=1)
            out["n_profiles"] = self.profiles_per_section * np.count_nonzero(X, axis=0)
        return out

    def volume_fractions(self) -> dict[str, float]:
        """Ratio estimates (paper eq. 1) of every reference component."""
        Q = self.reference_counts()
        tot = Q.sum()
        if tot <= 0:
            raise ValidationError("counts", "no point in the reference space", "a positive reference count")
        return {c: float(Q[:, j].sum() / tot) for j, c in enumerate(self.reference_components)}

    def summary(self) -> dict[str, dict[str, float]]:
        """V_V and every CE predictor per reference component (the table the CLI prints).

        Keys per component: ``V_V``; ``CE_m0``, ``CE_m1``, ``CE_q_hat`` (ratio form with covariance
        and nugget, :func:`fraction_covariance`); ``q_hat``; ``CE_classic`` (independent units,
        Cochran); ``CE_sum_m0`` / ``CE_sum_m1`` (of the component's point sum alone).
        """
        V = np.array(list(self.volume_fractions().values()))  # refuses an empty reference space
        Q = self.reference_counts()
        P = Q.sum(axis=1)
        kw = self.ce_kwargs()
        ce = {}
        for key, sm in (("CE_m0", 0), ("CE_m1", 1), ("CE_q_hat", "q_hat")):
            if sm == "q_hat" and len(P) < 5:
                ce[key] = np.full(len(V), np.nan)
                continue
            cov = fraction_covariance(Q, smoothness=sm, **kw)
            ce[key] = np.sqrt(np.clip(np.diag(cov), 0, None)) / V
        nprof = kw.get("n_profiles")
        out = {}
        for j, c in enumerate(self.reference_components):
            q = Q[:, j]
            r = {"V_V": float(V[j])}
            r.update({k: float(v[j]) for k, v in ce.items()})
            nuP = nugget_variance(P, shape_factor=self.shape_factor, n_profiles=None if nprof is None else nprof[-1])
            r["q_hat"] = float(smoothness_q_hat(P, nugget=nuP)) if len(P) >= 5 else float("nan")
            r["CE_classic"] = float(classic_ratio_ce(q, P))
            npj = None if nprof is None else nprof[j]
            for m in (0, 1):
                r[f"CE_sum_m{m}"] = float(ce_sum(q, smoothness=m, shape_factor=self.shape_factor, n_profiles=npj))
            out[c] = r
        return out
