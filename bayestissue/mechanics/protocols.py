r"""Loading protocols of a uniaxial test: the nominal stress :math:`P_{11}(t) = F(t) / (L_y L_z)` over time.

Three kinds, registered by name in :data:`PROTOCOLS` (the ``kind`` key of an experiment file):

- ``creep``: constant nominal stress :math:`P_{11}(t) = P_0` for :math:`t > 0` (the paper's T1, 10.6 kPa);
- ``ramp``: a pre-stress hold then a linear increase,
  :math:`P_{11}(t) = P_h` for :math:`0 < t \le t_h` and :math:`P_h + r (t - t_h)` after (the paper's T2:
  1.6 kPa for 240 s then +3.24 kPa/min = 20 mN/min on its 1.71 x 3.61 mm cross-section);
- ``measured``: a measured force history :math:`F(t_i)` given as samples, linearly interpolated (held constant
  beyond the last sample).

Every protocol starts unloaded: the state at :math:`t = 0` is the reference one, the load acts from the first
simulation step on (docs/model.md, initial state).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError, check_finite, check_increasing, check_positive

__all__ = [
    "CreepProtocol",
    "RampProtocol",
    "MeasuredForceProtocol",
    "PROTOCOLS",
    "protocol_from_mapping",
]


@dataclass(frozen=True)
class CreepProtocol:
    """Constant nominal stress ``stress_kpa`` from the first step on (paper test T1)."""

    stress_kpa: float
    kind = "creep"

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
    """A measured force history: samples ``force_mN`` at ``time_s``, linearly interpolated."""

    time_s: np.ndarray
    force_mN: np.ndarray
    kind = "measured"

    def __post_init__(self):
        t = check_increasing("protocol force time_s", self.time_s)
        f = np.asarray(self.force_mN, dtype=float)
        if f.shape != t.shape:
            raise ValidationError("protocol force_mN", f"{f.size} samples", f"{t.size} (one per time sample)")
        bad = np.flatnonzero(~np.isfinite(f))
        if bad.size:
            raise ValidationError("force_mN", f"{f[bad[0]]} at row {bad[0]}", "finite values")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "force_mN", f)

    def nominal_stress_kpa(self, time_s: np.ndarray, area_mm2: float) -> np.ndarray:
        t = np.asarray(time_s, dtype=float)
        return np.where(t > 0, np.interp(t, self.time_s, self.force_mN) / area_mm2, 0.0)

    @classmethod
    def from_mapping(cls, d: dict, *, columns: dict | None = None, **_):
        col = d.get("force_column", "force_mN")
        if not columns or col not in columns or "time_s" not in columns:
            raise ValidationError(
                "protocol.kind",
                "measured",
                f"a data file with columns time_s and {col}",
                "a measured protocol takes its load from the data file",
            )
        return cls(time_s=columns["time_s"], force_mN=columns[col])


#: Protocol classes by the ``kind`` name used in experiment files.
PROTOCOLS = {cls.kind: cls for cls in (CreepProtocol, RampProtocol, MeasuredForceProtocol)}


def protocol_from_mapping(d: dict, *, columns: dict | None = None):
    """Build a protocol from the ``[protocol]`` table of an experiment file."""
    kind = d.get("kind")
    if kind not in PROTOCOLS:
        raise ValidationError("protocol.kind", kind, f"one of {sorted(PROTOCOLS)}")
    return PROTOCOLS[kind].from_mapping(d, columns=columns)


def _require(d: dict, key: str):
    if key not in d:
        raise ValidationError(f"protocol.{key}", "missing", f"a value for {key!r} with kind = {d.get('kind')!r}")
    return d[key]
