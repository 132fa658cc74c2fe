"""Experiments: a specimen, a loading protocol, the data times (and data) and the fixed tissue inputs.

Experiment file format (TOML, with a CSV data file beside it)::

    name = "T1"
    description = "Creep test T1 (paper Section 3.2)"
    synthetic = true                      # true for simulated replicas; omit or false for measured data

    [specimen]
    length_x_mm = 5.33                    # loading direction
    length_y_mm = 2.43
    length_z_mm = 3.9

    [protocol]
    kind = "creep"                        # creep | ramp | measured | stretch_ramp | stretch_cycles | measured_stretch
                                          # | shear_ramp | measured_shear
    mode = "uniaxial"                     # the load case: uniaxial | equibiaxial | biaxial | pure_shear | simple_shear
    stress_kpa = 10.6                     # creep: constant nominal stress
    # ramp:     hold_stress_kpa, hold_s, rate_kpa_per_s
    # measured: the load is the data file's force column (force_column, default "force_mN")
    # stretch_ramp: stretch, ramp_s; stretch_cycles: stretch, period_s
    # measured_stretch: the stretch is the data file's stretch column (or displacement_mm / length_x_mm)

    [simulation]
    dt_s = 6.0                            # simulation step, independent of the data step

    [data]
    file = "T1.csv"                       # columns time_s, displacement_mm, force_mN, stretch, nominal_stress_kpa
    # or, for a simulation-only experiment without a data file:
    # duration_s = 1200.0
    # step_s = 3.0

    [tissue]                              # optional; defaults are the paper's (docs/model.md)
    preset = "slug"                       # slug | tendon | brain | rubber (docs/presets.md); keys below override
    directions = [[0, 1, 0], [0.9369, 0.342, 0], [0.9369, -0.342, 0]]
    phi_fibres = [0.2, 0.2, 0.2]
    phi_matrix = 0.4
    bulk_kpa = 1000.0
    eps0 = [0, 0, 0]
    matrix = "mooney_rivlin"              # the laws (docs/laws.md): matrix, its terms (Ogden), fibre, recruitment
    fibre = "linear"                      # (hgo), Prony branches of each: matrix_branches = 0, fibre_branches = 1
    fibre_branches = 1

A data file's ``# noise_sd_mm: ...`` header line (written for synthetic replicas) is kept as ``noise_sd_mm``.

What is observed is the load case's (:attr:`Experiment.channels`, :mod:`bayestissue.mechanics.loadcases`): under
force control the displacement of the loaded face (``displacement_mm``); under stretch control the force on it
(``force_mN``) or, where the data give only that, the nominal stress (``nominal_stress_kpa``); a biaxial test both
loaded faces (``..._2_...`` columns), simple shear the shear stress (``shear_stress_kpa``) or force.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError, check_increasing, check_positive
from bayestissue.io.tables import read_table
from bayestissue.io.toml_files import read_toml
from bayestissue.mechanics.branches import with_second_branch
from bayestissue.mechanics.experiment_schema import check_experiment_document
from bayestissue.mechanics.laws import fibre_law, matrix_law
from bayestissue.mechanics.loadcases import Channel, LoadCase, Uniaxial, load_case
from bayestissue.mechanics.presets import preset
from bayestissue.mechanics.protocols import protocol_from_mapping
from bayestissue.mechanics.tissue import PAPER_TISSUE, TissueConfig

__all__ = ["Experiment", "load_experiment", "MIN_STEPS", "MAX_STEPS"]

#: The simulation grid's range of steps over the data's duration: with one step the interpolated curve is a straight
#: line from the first step to the last data time (dt_s = 1e9 gave a flat curve); above MAX_STEPS the batched forward
#: stores (n_steps + 1) x batch states and the solve takes minutes per curve (dt_s = 1e-9 asked for 8.7 TiB).
MIN_STEPS = 2
MAX_STEPS = 1_000_000
#: Data columns kept as named fields of :class:`Experiment` (the others go to ``columns``).
_FIELDS = {"displacement_mm": "displacement_mm", "force_mN": "force_mN", "nominal_stress_kpa": "stress_kpa"}


@dataclass(frozen=True, eq=False)
class Experiment:
    """A uniaxial experiment.

    Parameters
    ----------
    name : str
    specimen_mm : (3,) tuple of float
        Specimen size (L_x, L_y, L_z) in mm, x the loading direction.
    protocol : CreepProtocol | RampProtocol | MeasuredForceProtocol
    time_s : (n_obs,) ndarray
        Data times (s), strictly increasing, >= 0.
    dt_s : float
        Simulation step (s). The simulation grid is ``t_n = n dt_s`` up to the last data time; the displacement is
        linearly interpolated to the data times.
    displacement_mm, force_mN, stress_kpa : (n_obs,) ndarray or None
        Displacement of the loaded face, force on it and nominal stress P11, where the data file gives them.
    tissue : TissueConfig
        Fibre directions, volume fractions, bulk modulus, slack strains (default: the paper's).
    noise_sd_mm : float or None
        Measurement noise sd where known (synthetic replicas record it).
    source, data_file : the experiment file and the data file it was read from (the run's provenance hashes both).
    load_case : the homogeneous test the protocol drives (default uniaxial along x).
    columns : every numeric column of the data file (the observed channels beyond the three above: a biaxial
        test's second face, simple shear's stress).
    """

    name: str
    specimen_mm: tuple[float, float, float]
    protocol: object
    time_s: np.ndarray
    dt_s: float
    displacement_mm: np.ndarray | None = None
    force_mN: np.ndarray | None = None
    stress_kpa: np.ndarray | None = None
    tissue: TissueConfig = PAPER_TISSUE
    noise_sd_mm: float | None = None
    synthetic: bool = False
    description: str = ""
    source: str | None = None
    data_file: str | None = None
    meta: dict = field(default_factory=dict)
    load_case: LoadCase = field(default_factory=Uniaxial)
    columns: dict = field(default_factory=dict)

    def __post_init__(self):
        dims = tuple(
            check_positive(f"specimen.length_{ax}_mm", v) for ax, v in zip("xyz", self.specimen_mm, strict=True)
        )
        object.__setattr__(self, "specimen_mm", dims)
        dt = check_positive("simulation.dt_s", self.dt_s)
        object.__setattr__(self, "dt_s", dt)
        t = check_increasing("time_s", self.time_s)
        if t[0] < 0:
            raise ValidationError("time_s", float(t[0]), "times >= 0 (t = 0 is the unloaded state)")
        t.setflags(write=False)
        object.__setattr__(self, "time_s", t)
        span = float(t[-1])
        if span > 0 and not (span / MAX_STEPS <= dt <= span / MIN_STEPS):
            raise ValidationError(
                "simulation.dt_s",
                dt,
                f"a step in [{span / MAX_STEPS:.3g}, {span / MIN_STEPS:.3g}] s for the data's {span:g} s "
                f"({MIN_STEPS} to {MAX_STEPS:.0e} steps)",
                "a smaller step cannot be stored, a larger one cannot follow the test",
            )
        for name in ("displacement_mm", "force_mN", "stress_kpa"):
            v = getattr(self, name)
            if v is None:
                continue
            v = np.asarray(v, dtype=float)
            if v.shape != t.shape:
                raise ValidationError(name, f"{v.size} values", f"{t.size} values (one per data time)")
            bad = np.flatnonzero(~np.isfinite(v))
            if bad.size:
                raise ValidationError(name, f"{v[bad[0]]} at row {bad[0]} (time {t[bad[0]]} s)", "finite values")
            v.setflags(write=False)
            object.__setattr__(self, name, v)
        if self.noise_sd_mm is not None:
            object.__setattr__(self, "noise_sd_mm", check_positive("noise_sd_mm", self.noise_sd_mm))
        if not isinstance(self.tissue, TissueConfig):
            raise ValidationError("tissue", type(self.tissue).__name__, "a TissueConfig")
        if not isinstance(self.load_case, LoadCase):
            raise ValidationError("load_case", type(self.load_case).__name__, "a LoadCase")
        self.load_case.check_controls(self.controls)
        if (
            getattr(self.protocol, "stretch_2", None) is not None
            or getattr(self.protocol, "force_2_mN", None) is not None
        ):
            self.load_case.check_second_history()
        cols = {k: np.asarray(v, dtype=float) for k, v in dict(self.columns).items() if k not in _FIELDS}
        for name, v in cols.items():
            if v.shape != t.shape:
                raise ValidationError(name, f"{v.size} values", f"{t.size} values (one per data time)")
            v.setflags(write=False)
        object.__setattr__(self, "columns", cols)

    @property
    def area_mm2(self) -> float:
        """Reference cross-section L_y L_z (mm^2)."""
        return self.specimen_mm[1] * self.specimen_mm[2]

    @property
    def n_steps(self) -> int:
        """Number of simulation steps: the grid ``n dt`` covers the last data time."""
        return max(1, math.ceil(self.time_s[-1] / self.dt_s - 1e-9))

    @property
    def step_time_s(self) -> np.ndarray:
        """(n_steps + 1,) simulation grid ``t_n = n dt``."""
        return np.arange(self.n_steps + 1) * self.dt_s

    @property
    def controls(self) -> str:
        """What the protocol prescribes: ``"force"`` or ``"stretch"``."""
        return self.protocol.controls

    def nominal_stress_kpa(self) -> np.ndarray:
        """(n_steps + 1,) nominal stress P11 at the simulation steps (0 at t = 0) of a force-controlled test."""
        if self.controls != "force":
            raise ValidationError(f"experiment {self.name}", self.protocol.kind, "a force-controlled protocol")
        return self.protocol.nominal_stress_kpa(self.step_time_s, self.area_mm2)

    def prescribed(self) -> np.ndarray:
        """(n_steps + 1,) the driving history at the simulation steps: the nominal stress (kPa, 0 at t = 0) under
        force control, the stretch of the loaded face (1 at t = 0) under stretch control, the amount of shear (0 at
        t = 0) under shear control; ``(n_steps + 1, 2)`` for a biaxial test whose second face has its own stretch or
        force history (:class:`~bayestissue.mechanics.protocols.MeasuredStretchProtocol`,
        :class:`~bayestissue.mechanics.protocols.MeasuredForceProtocol`)."""
        if self.controls == "force":
            lx, _, lz = self.specimen_mm
            second = getattr(self.protocol, "nominal_stress_2_kpa", lambda *_: None)(self.step_time_s, lx * lz)
            first = self.nominal_stress_kpa()
            return first if second is None else np.column_stack([first, second])
        if self.controls == "shear":
            g = np.asarray(self.protocol.shear_at(self.step_time_s), dtype=float)
            g[0] = 0.0
            return g
        lam = np.asarray(self.protocol.stretch_at(self.step_time_s), dtype=float)
        lam[0] = 1.0
        second = getattr(self.protocol, "stretch_2_at", lambda _: None)(self.step_time_s)
        if second is None:
            return lam
        second = np.asarray(second, dtype=float)
        second[0] = 1.0
        return np.column_stack([lam, second])

    @property
    def channels(self) -> tuple[Channel, ...]:
        """What the forward model predicts, channel by channel (:mod:`bayestissue.mechanics.loadcases`)."""
        return self.load_case.channels(self.controls, self.data_columns, self.specimen_mm)

    def data_of(self, channel: Channel) -> np.ndarray | None:
        """The observed data of ``channel`` (None if the data file has no such column)."""
        if channel.column in _FIELDS:
            return getattr(self, _FIELDS[channel.column])
        return self.columns.get(channel.column)

    @property
    def data_columns(self) -> set[str]:
        """The data columns present (the named fields and the extra columns)."""
        return {c for c, f in _FIELDS.items() if getattr(self, f) is not None} | set(self.columns)

    @property
    def observable(self) -> tuple[str, str, np.ndarray | None]:
        """``(quantity, unit, data)`` of the first channel: ``("displacement", "mm", displacement_mm)`` under force
        control; under stretch control ``("force", "mN", force_mN)``, or ``("nominal stress", "kPa", stress_kpa)``
        when the data file has no force column."""
        ch = self.channels[0]
        return ch.quantity, ch.unit, self.data_of(ch)

    @property
    def observed(self) -> np.ndarray | None:
        """The observed data (:attr:`observable`), or None for a simulation-only experiment."""
        return self.observable[2]

    def interpolation(self) -> tuple[np.ndarray, np.ndarray]:
        """Indices ``i`` and weights ``w`` with ``u(t_obs) = (1 - w) u[i] + w u[i + 1]`` on the step grid.

        Linear interpolation between steps, except in the first interval: the load acts from the first step on, so
        a data time ``0 < t < dt`` takes the state of step 1 (interpolating towards the unloaded state at t = 0
        would invent a response to a load that was never applied in the model).
        """
        grid = self.step_time_s
        i = np.clip(np.searchsorted(grid, self.time_s, side="right") - 1, 0, grid.size - 2)
        w = (self.time_s - grid[i]) / self.dt_s
        w = np.where((i == 0) & (self.time_s > 0), 1.0, w)
        return i, w


def _table(doc: dict, key: str) -> dict:
    val = doc.get(key)
    if not isinstance(val, dict):
        raise ValidationError(f"[{key}]", "missing" if val is None else val, f"a [{key}] table")
    return val


def _get(table: dict, key: str, section: str):
    if key not in table:
        raise ValidationError(f"{section}.{key}", "missing", f"a value for {key!r}")
    return table[key]


def load_experiment(path: str | Path) -> Experiment:
    """Read an experiment file (TOML) and its data file (CSV, path relative to the TOML file).

    Raises
    ------
    FileNotFoundError if either file is missing; ValidationError (a ValueError) naming the file, the field, the
    value and what was expected for any bad or missing entry (the data file's own errors name the data file, its
    line and column).
    """
    path = Path(path)
    doc = read_toml(path, "experiment")
    check_experiment_document(doc, path.name)
    data = doc.get("data")
    columns, meta, data_file = {}, {}, None
    if isinstance(data, dict) and "file" in data:
        data_file = path.parent / data["file"]
        columns, meta = read_table(data_file, required=("time_s",), numeric=True)
    try:
        return _build(doc, path, columns, meta, data_file)
    except ValidationError as exc:
        raise exc.within(path.name) from None


def _build(doc: dict, path: Path, columns: dict, meta: dict, data_file: Path | None) -> Experiment:
    spec = _table(doc, "specimen")
    dims = tuple(_get(spec, f"length_{ax}_mm", "specimen") for ax in "xyz")
    dt = _get(_table(doc, "simulation"), "dt_s", "simulation")
    data = _table(doc, "data")
    if data_file is not None:
        time_s = columns["time_s"]
    else:
        duration = check_positive("data.duration_s", _get(data, "duration_s", "data"))
        step = check_positive("data.step_s", _get(data, "step_s", "data"))
        if step > duration:  # one row (t = 0) would be all that is simulated
            raise ValidationError("data.step_s", step, f"a step at most data.duration_s ({duration:g} s)")
        time_s = np.arange(0.0, duration + 0.5 * step, step)
    prot = _table(doc, "protocol")
    protocol = protocol_from_mapping(prot, columns=columns, length_x_mm=dims[0])
    case = load_case(prot.get("mode", "uniaxial"), **({"ratio": prot["ratio"]} if "ratio" in prot else {}))
    tissue = PAPER_TISSUE
    if "tissue" in doc:
        t = doc["tissue"]
        base = preset(t.get("preset", "slug"))
        matrix = base.tissue.matrix
        if "matrix" in t or "terms" in t:
            matrix = matrix_law(t.get("matrix", matrix.name), **({"terms": t["terms"]} if "terms" in t else {}))
        fibre = base.tissue.fibre
        if "fibre" in t or "recruitment" in t:
            opts = {"recruitment": t["recruitment"]} if "recruitment" in t else {}
            fibre = fibre_law(t.get("fibre", fibre.name), **opts)
        tissue = TissueConfig(
            directions=t.get("directions", base.tissue.directions),
            phi_fibres=t.get("phi_fibres", base.tissue.phi_fibres),
            phi_matrix=t.get("phi_matrix", base.tissue.phi_matrix),
            bulk_kpa=t.get("bulk_kpa", base.tissue.bulk_kpa),
            eps0=t.get("eps0"),
            preset=base.name,
            matrix=matrix,
            fibre=fibre,
            matrix_branches=t.get("matrix_branches", base.tissue.matrix_branches),
            fibre_branches=t.get("fibre_branches", base.tissue.fibre_branches),
        )
        tissue = with_second_branch(tissue, t.get("second_branch", []))
    noise = meta.get("noise_sd_mm")
    if noise is not None:
        try:
            noise = float(noise)
        except ValueError:
            raise ValidationError(f"{data_file.name} header noise_sd_mm", noise, "a number > 0") from None
    return Experiment(
        name=str(doc.get("name", path.stem)),
        specimen_mm=dims,
        protocol=protocol,
        time_s=time_s,
        dt_s=dt,
        displacement_mm=columns.get("displacement_mm"),
        force_mN=columns.get("force_mN"),
        stress_kpa=columns.get("nominal_stress_kpa"),
        tissue=tissue,
        noise_sd_mm=noise,
        synthetic=bool(doc.get("synthetic", False)),
        description=str(doc.get("description", "")),
        source=str(path),
        data_file=None if data_file is None else str(data_file),
        meta=meta,
        load_case=case,
        columns={k: v for k, v in columns.items() if k != "time_s"},
    )
