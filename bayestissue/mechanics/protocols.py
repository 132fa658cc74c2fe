r"""Loading protocols of a uniaxial test: what is prescribed on the loaded face over time.

Force-controlled kinds (``controls = "force"``) prescribe the nominal stress :math:`P_{11}(t) = F(t) / (L_y L_z)`;
the observable is the displacement of the loaded face:

- ``creep``: constant nominal stress :math:`P_{11}(t) = P_0` for :math:`t > 0` (the paper's T1, 10.6 kPa);
- ``ramp``: a pre-stress hold then a linear increase,
  :math:`P_{11}(t) = P_h` for :math:`0 < t \le t_h` and :math:`P_h + r (t - t_h)` after (the paper's T2:
  1.6 kPa for 240 s then +3.24 kPa/min = 20 mN/min on its 1.71 x 3.61 mm cross-section);
- ``measured``: a measured force history :math:`F(t_i)` given as samples, linearly interpolated (held constant
  beyond the last sample); for a planar biaxial test (``mode = "biaxial"``) a second column ``force_2_mN`` loads the
  second face independently of the first.

Displacement-controlled kinds (``controls = "stretch"``) prescribe the stretch of the loaded face
:math:`\lambda(t) = 1 + u(t)/L_x`; the observable is the force on it (or the nominal stress, where the data give
that):

- ``stretch_ramp``: a constant-rate ramp to ``stretch`` over ``ramp_s`` seconds, then held (stress relaxation);
  a ramp longer than the data is a constant strain-rate test: :math:`\lambda(t) = 1 + (\lambda_p - 1)\min(t /
  t_r, 1)`;
- ``stretch_cycles``: loading-unloading cycles between 1 and ``stretch`` with period ``period_s`` (a triangle
  wave, :math:`\lambda(t) = 1 + (\lambda_p - 1)(1 - |1 - 2 \{t / T\}|)`, :math:`\{\cdot\}` the fractional
  part);
- ``measured_stretch``: a measured stretch history (the data file's ``stretch`` column, or ``displacement_mm``
  divided by the specimen length), linearly interpolated; for a planar biaxial test (``mode = "biaxial"``) a second
  column ``stretch_2`` prescribes the second face's stretch independently of the first (non-proportional loading:
  several ratios in sequence, one axis held while the other moves).

Shear-controlled kinds (``controls = "shear"``, for the simple-shear load case) prescribe the amount of shear
:math:`\gamma(t)`:

- ``shear_ramp``: a constant-rate ramp to ``shear`` over ``ramp_s`` seconds, then held;
- ``measured_shear``: a measured history (the data file's ``shear`` column), linearly interpolated.

Every protocol starts unloaded: the state at :math:`t = 0` is the reference one, the load acts from the first
simulation step on (docs/model.md, initial state). Which faces the history acts on is the load case's
(``[protocol] mode``, :mod:`bayestissue.mechanics.loadcases`; uniaxial by default).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError, check_finite, check_increasing, check_positive

__all__ = [
    "CreepProtocol",
    "RampProtocol",
    "MeasuredForceProtocol",
    "StretchRampProtocol",
    "StretchCyclesProtocol",
    "MeasuredStretchProtocol",
    "ShearRampProtocol",
    "MeasuredShearProtocol",
    "PROTOCOLS",
    "protocol_from_mapping",
]


@dataclass(frozen=True)
class CreepProtocol:
    """Constant nominal stress ``stress_kpa`` from the first step on (paper test T1)."""

    stress_kpa: float
    kind = "creep"
    controls = "force"

    def __post_init__(self):
        check_finite("protocol.stress_kpa", self.stress_kpa)

    def nominal_stress_kpa(self, time_s: np.ndarray, area_mm2: float) -> np.ndarray:
        t = np.asarray(time_s, dtype=float)
        return np.where(t > 0, float(self.stress_kpa), 0.0)

    @classmethod
    def from_mapping(cls, d: dict, **_):
        return cls(stress_kpa=_require(d, "stress_kpa"))


@dataclass(frozen=True)
class RampProtocol:
    """Hold ``hold_stress_kpa`` for ``hold_s`` seconds, then increase at ``rate_kpa_per_s`` (paper test T2)."""

    hold_stress_kpa: float
    hold_s: float
    rate_kpa_per_s: float
    kind = "ramp"
    controls = "force"

    def __post_init__(self):
        check_finite("protocol.hold_stress_kpa", self.hold_stress_kpa)
        check_positive("protocol.hold_s", self.hold_s, allow_zero=True)
        check_finite("protocol.rate_kpa_per_s", self.rate_kpa_per_s)

    def nominal_stress_kpa(self, time_s: np.ndarray, area_mm2: float) -> np.ndarray:
        t = np.asarray(time_s, dtype=float)
        p = self.hold_stress_kpa + self.rate_kpa_per_s * np.clip(t - self.hold_s, 0.0, None)
        return np.where(t > 0, p, 0.0)

    @classmethod
    def from_mapping(cls, d: dict, **_):
        return cls(
            hold_stress_kpa=_require(d, "hold_stress_kpa"),
            hold_s=_require(d, "hold_s"),
            rate_kpa_per_s=_require(d, "rate_kpa_per_s"),
        )


@dataclass(frozen=True, eq=False)
class MeasuredForceProtocol:
    """A measured force history: samples ``force_mN`` at ``time_s``, linearly interpolated; optionally the second
    face's own force history ``force_2_mN`` (a biaxial test under two independent dead loads)."""

    time_s: np.ndarray
    force_mN: np.ndarray
    force_2_mN: np.ndarray | None = None
    kind = "measured"
    controls = "force"

    def __post_init__(self):
        t = check_increasing("protocol force time_s", self.time_s)
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "force_mN", self._checked("force_mN", self.force_mN))
        if self.force_2_mN is not None:
            object.__setattr__(self, "force_2_mN", self._checked("force_2_mN", self.force_2_mN))

    def _checked(self, name: str, values) -> np.ndarray:
        f = np.asarray(values, dtype=float)
        if f.shape != self.time_s.shape:
            raise ValidationError(f"protocol {name}", f"{f.size} samples", f"{self.time_s.size} (one per time sample)")
        bad = np.flatnonzero(~np.isfinite(f))
        if bad.size:
            raise ValidationError(name, f"{f[bad[0]]} at row {bad[0]}", "finite values")
        return f

    def nominal_stress_kpa(self, time_s: np.ndarray, area_mm2: float) -> np.ndarray:
        t = np.asarray(time_s, dtype=float)
        return np.where(t > 0, np.interp(t, self.time_s, self.force_mN) / area_mm2, 0.0)

    def nominal_stress_2_kpa(self, time_s: np.ndarray, area_mm2: float) -> np.ndarray | None:
        """The second face's nominal stress (``area_mm2`` its reference area; None without a second history)."""
        if self.force_2_mN is None:
            return None
        t = np.asarray(time_s, dtype=float)
        return np.where(t > 0, np.interp(t, self.time_s, self.force_2_mN) / area_mm2, 0.0)

    @classmethod
    def from_mapping(cls, d: dict, *, columns: dict | None = None, **_):
        col, col2 = d.get("force_column", "force_mN"), d.get("force_2_column", "force_2_mN")
        if not columns or col not in columns or "time_s" not in columns:
            raise ValidationError(
                "protocol.kind",
                "measured",
                f"a data file with columns time_s and {col}",
                "a measured protocol takes its load from the data file",
            )
        if "force_2_column" in d and col2 not in columns:
            raise ValidationError("protocol.force_2_column", col2, f"a column of the data file {sorted(columns)}")
        return cls(time_s=columns["time_s"], force_mN=columns[col], force_2_mN=columns.get(col2))


@dataclass(frozen=True)
class StretchRampProtocol:
    """A constant-rate stretch ramp to ``stretch`` over ``ramp_s`` seconds, then held (relaxation)."""

    stretch: float
    ramp_s: float
    kind = "stretch_ramp"
    controls = "stretch"

    def __post_init__(self):
        check_positive("protocol.stretch", self.stretch)
        check_positive("protocol.ramp_s", self.ramp_s)

    def stretch_at(self, time_s: np.ndarray) -> np.ndarray:
        t = np.asarray(time_s, dtype=float)
        return 1.0 + (self.stretch - 1.0) * np.clip(t / self.ramp_s, 0.0, 1.0)

    @classmethod
    def from_mapping(cls, d: dict, **_):
        return cls(stretch=_require(d, "stretch"), ramp_s=_require(d, "ramp_s"))


@dataclass(frozen=True)
class StretchCyclesProtocol:
    """Loading-unloading cycles between 1 and ``stretch``, period ``period_s`` (triangle wave)."""

    stretch: float
    period_s: float
    kind = "stretch_cycles"
    controls = "stretch"

    def __post_init__(self):
        check_positive("protocol.stretch", self.stretch)
        check_positive("protocol.period_s", self.period_s)

    def stretch_at(self, time_s: np.ndarray) -> np.ndarray:
        phase = np.mod(np.asarray(time_s, dtype=float) / self.period_s, 1.0)
        return 1.0 + (self.stretch - 1.0) * (1.0 - np.abs(1.0 - 2.0 * phase))

    @classmethod
    def from_mapping(cls, d: dict, **_):
        return cls(stretch=_require(d, "stretch"), period_s=_require(d, "period_s"))


@dataclass(frozen=True, eq=False)
class MeasuredStretchProtocol:
    """A measured stretch history: samples ``stretch`` at ``time_s``, linearly interpolated (held beyond the last);
    optionally the second face's own history ``stretch_2`` (a biaxial test, module docstring).

    The state at t = 0 is the reference: a sample at t = 0 must have stretch 1; without one, (0, 1) is the first
    point of the interpolation.
    """

    time_s: np.ndarray
    stretch: np.ndarray
    stretch_2: np.ndarray | None = None
    kind = "measured_stretch"
    controls = "stretch"

    def __post_init__(self):
        t = check_increasing("protocol stretch time_s", self.time_s)
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "stretch", self._checked("stretch", self.stretch))
        if self.stretch_2 is not None:
            object.__setattr__(self, "stretch_2", self._checked("stretch_2", self.stretch_2))

    def _checked(self, name: str, values) -> np.ndarray:
        t = self.time_s
        lam = np.asarray(values, dtype=float)
        if lam.shape != t.shape:
            raise ValidationError(f"protocol {name}", f"{lam.size} samples", f"{t.size} (one per time sample)")
        bad = np.flatnonzero(~(np.isfinite(lam) & (lam > 0)))
        if bad.size:
            raise ValidationError(name, f"{lam[bad[0]]} at row {bad[0]}", "finite stretches > 0")
        if t[0] == 0 and abs(lam[0] - 1.0) > 1e-9:
            raise ValidationError(
                f"{name} at time_s = 0",
                float(lam[0]),
                "1 (t = 0 is the unloaded reference state)",
                "start the times after 0 if the first sample is already stretched",
            )
        return lam

    def stretch_at(self, time_s: np.ndarray) -> np.ndarray:
        t = np.asarray(time_s, dtype=float)
        return np.interp(t, np.r_[0.0, self.time_s], np.r_[1.0, self.stretch])

    def stretch_2_at(self, time_s: np.ndarray) -> np.ndarray | None:
        """The second face's stretch at ``time_s`` (None without a second history)."""
        if self.stretch_2 is None:
            return None
        t = np.asarray(time_s, dtype=float)
        return np.interp(t, np.r_[0.0, self.time_s], np.r_[1.0, self.stretch_2])

    @classmethod
    def from_mapping(cls, d: dict, *, columns: dict | None = None, length_x_mm: float | None = None, **_):
        columns = columns or {}
        col, col2 = d.get("stretch_column", "stretch"), d.get("stretch_2_column", "stretch_2")
        if "stretch_2_column" in d and col2 not in columns:
            raise ValidationError("protocol.stretch_2_column", col2, f"a column of the data file {sorted(columns)}")
        second = columns.get(col2) if "time_s" in columns else None
        if "time_s" in columns and col in columns:
            return cls(time_s=columns["time_s"], stretch=columns[col], stretch_2=second)
        if "time_s" in columns and "displacement_mm" in columns and "stretch_column" not in d and length_x_mm:
            return cls(time_s=columns["time_s"], stretch=1.0 + columns["displacement_mm"] / float(length_x_mm),
                       stretch_2=second)  # fmt: skip
        raise ValidationError(
            "protocol.kind",
            "measured_stretch",
            f"a data file with columns time_s and {col} (or displacement_mm)",
            "a measured stretch protocol takes its load from the data file",
        )


@dataclass(frozen=True)
class ShearRampProtocol:
    """A constant-rate ramp of the amount of shear to ``shear`` over ``ramp_s`` seconds, then held."""

    shear: float
    ramp_s: float
    kind = "shear_ramp"
    controls = "shear"

    def __post_init__(self):
        check_finite("protocol.shear", self.shear)
        check_positive("protocol.ramp_s", self.ramp_s)

    def shear_at(self, time_s: np.ndarray) -> np.ndarray:
        return self.shear * np.clip(np.asarray(time_s, dtype=float) / self.ramp_s, 0.0, 1.0)

    @classmethod
    def from_mapping(cls, d: dict, **_):
        return cls(shear=_require(d, "shear"), ramp_s=_require(d, "ramp_s"))


@dataclass(frozen=True, eq=False)
class MeasuredShearProtocol:
    """A measured history of the amount of shear (the data file's ``shear`` column), linearly interpolated; 0 at
    t = 0."""

    time_s: np.ndarray
    shear: np.ndarray
    kind = "measured_shear"
    controls = "shear"

    def __post_init__(self):
        t = check_increasing("protocol shear time_s", self.time_s)
        g = np.asarray(self.shear, dtype=float)
        if g.shape != t.shape:
            raise ValidationError("protocol shear", f"{g.size} samples", f"{t.size} (one per time sample)")
        bad = np.flatnonzero(~np.isfinite(g))
        if bad.size:
            raise ValidationError("shear", f"{g[bad[0]]} at row {bad[0]}", "finite amounts of shear")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "shear", g)

    def shear_at(self, time_s: np.ndarray) -> np.ndarray:
        return np.interp(np.asarray(time_s, dtype=float), np.r_[0.0, self.time_s], np.r_[0.0, self.shear])

    @classmethod
    def from_mapping(cls, d: dict, *, columns: dict | None = None, **_):
        columns = columns or {}
        col = d.get("shear_column", "shear")
        if "time_s" in columns and col in columns:
            return cls(time_s=columns["time_s"], shear=columns[col])
        raise ValidationError("protocol.kind", "measured_shear", f"a data file with columns time_s and {col}",
                              "a measured shear protocol takes its load from the data file")  # fmt: skip


#: Protocol classes by the ``kind`` name used in experiment files.
PROTOCOLS = {
    cls.kind: cls
    for cls in (
        CreepProtocol,
        RampProtocol,
        MeasuredForceProtocol,
        StretchRampProtocol,
        StretchCyclesProtocol,
        MeasuredStretchProtocol,
        ShearRampProtocol,
        MeasuredShearProtocol,
    )
}


def protocol_from_mapping(d: dict, *, columns: dict | None = None, length_x_mm: float | None = None):
    """Build a protocol from the ``[protocol]`` table of an experiment file (``length_x_mm`` turns a measured
    displacement history into a stretch)."""
    kind = d.get("kind")
    if kind not in PROTOCOLS:
        raise ValidationError("protocol.kind", kind, f"one of {sorted(PROTOCOLS)}")
    return PROTOCOLS[kind].from_mapping(d, columns=columns, length_x_mm=length_x_mm)


def _require(d: dict, key: str):
    if key not in d:
        raise ValidationError(f"protocol.{key}", "missing", f"a value for {key!r} with kind = {d.get('kind')!r}")
    return d[key]
