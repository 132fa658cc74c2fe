"""The experiment file's schema: its tables and keys, each with its type, range, default and meaning.

:func:`check_experiment_document` runs on the parsed TOML before anything is built from it, so that a typo
(``stres_kpa``, ``length_w_mm``, ``[tissue] fibre_directions``) is refused with the nearest valid name instead of
being ignored, and a value of the wrong type (``length_x_mm = true``, ``dt_s = "6"``) is refused instead of being
converted. The key kinds and checks are :mod:`bayestissue._schema`'s, shared with the calibration configuration.
What one key cannot say (fractions summing to 1, unit directions, the simulation step against the data's span) is
checked where the objects are built (:class:`~bayestissue.mechanics.experiment.Experiment`, the protocols,
:class:`~bayestissue.mechanics.tissue.TissueConfig`). :func:`experiment_markdown` renders ``docs/experiment.md``.
"""

from __future__ import annotations

from collections.abc import Mapping

from bayestissue._schema import Key, check_table, reference_rows
from bayestissue._validation import ValidationError, check_known_keys
from bayestissue.mechanics.laws import FIBRE_LAWS, MATRIX_LAWS
from bayestissue.mechanics.loadcases import LOAD_CASES
from bayestissue.mechanics.presets import PRESETS

__all__ = ["TABLES", "PROTOCOL_KEYS", "check_experiment_document", "experiment_markdown"]

_POSITIVE = {"low": 0.0, "low_open": True}

#: The ``[protocol]`` keys each kind takes (a ramp's ``stress_kpa`` is a mistake, not an extra).
PROTOCOL_KEYS = {
    "creep": ("kind", "mode", "ratio", "stress_kpa"),
    "ramp": ("kind", "mode", "ratio", "hold_stress_kpa", "hold_s", "rate_kpa_per_s"),
    "measured": ("kind", "mode", "ratio", "force_column", "force_2_column"),
    "stretch_ramp": ("kind", "mode", "ratio", "stretch", "ramp_s"),
    "stretch_cycles": ("kind", "mode", "ratio", "stretch", "period_s"),
    "measured_stretch": ("kind", "mode", "ratio", "stretch_column", "stretch_2_column"),
    "shear_ramp": ("kind", "mode", "shear", "ramp_s"),
    "measured_shear": ("kind", "mode", "shear_column"),
}

#: The keys of each table ("" is the top level).
TABLES: dict[str, dict[str, Key]] = {
    "": {
        "name": Key("text", "the file's stem", "the experiment's name in tables, figures and noise parameters"),
        "description": Key("text", '""', "free text"),
        "synthetic": Key("bool", "false", "true for simulated replicas (never present them as measured)"),
    },
    "specimen": {
        "length_x_mm": Key("float", "required", "specimen length along the load (mm)", **_POSITIVE),
        "length_y_mm": Key("float", "required", "cross-section side (mm)", **_POSITIVE),
        "length_z_mm": Key("float", "required", "cross-section side (mm)", **_POSITIVE),
    },
    "protocol": {
        "kind": Key("choice", "required", "force control: creep, ramp, a measured force history; stretch control: "
                    "stretch_ramp, stretch_cycles, a measured stretch history; shear control (simple shear): "
                    "shear_ramp, a measured shear history",
                    choices=tuple(PROTOCOL_KEYS)),
        "mode": Key("choice", '"uniaxial"', "the load case the history drives (docs/laws.md): uniaxial (tension or "
                    "compression), equibiaxial, biaxial, pure_shear, simple_shear", choices=tuple(LOAD_CASES)),
        "ratio": Key("float", "1", "biaxial: (lambda_2 - 1)/(lambda_1 - 1) under stretch control, P_2/P_1 under "
                     "force control"),
        "stress_kpa": Key("float", "required (creep)", "constant nominal stress from the first step on (kPa)"),
        "hold_stress_kpa": Key("float", "required (ramp)", "nominal stress held first (kPa)"),
        "hold_s": Key("float", "required (ramp)", "duration of the hold (s)", low=0.0),
        "rate_kpa_per_s": Key("float", "required (ramp)", "rate of the nominal stress after the hold (kPa/s)"),
        "force_column": Key("text", '"force_mN"', "the data file's force column (measured)"),
        "force_2_column": Key("text", '"force_2_mN"', "biaxial: the data file's column of the second face's force, "
                              "applied independently of the first (measured with mode = 'biaxial'; without the "
                              "column, the ratio applies)"),
        "stretch": Key("float", "required (stretch_ramp, stretch_cycles)", "peak stretch of the loaded face",
                       **_POSITIVE),
        "ramp_s": Key("float", "required (stretch_ramp)", "duration of the ramp to the peak, then held (s)",
                      **_POSITIVE),
        "period_s": Key("float", "required (stretch_cycles)", "period of a loading-unloading cycle (s)", **_POSITIVE),
        "stretch_column": Key("text", '"stretch"', "the data file's stretch column (measured_stretch; without it, "
                              "displacement_mm / length_x_mm)"),
        "stretch_2_column": Key("text", '"stretch_2"', "biaxial: the data file's column of the second face's stretch, "
                                "prescribed independently of the first (measured_stretch with mode = 'biaxial'; "
                                "without the column, the ratio applies)"),
        "shear": Key("float", "required (shear_ramp)", "amount of shear gamma reached by the ramp"),
        "shear_column": Key("text", '"shear"', "the data file's amount-of-shear column (measured_shear)"),
    },
    "simulation": {
        "dt_s": Key("float", "required", "simulation step (s), 2 to 10^6 steps over the data's span", **_POSITIVE),
    },
    "data": {
        "file": Key("text", "none", "CSV beside the experiment file: time_s, displacement_mm, force_mN, stretch, "
                    "nominal_stress_kpa"),
        "duration_s": Key("float", "without file", "simulated duration (s)", **_POSITIVE),
        "step_s": Key("float", "without file", "output step (s)", **_POSITIVE),
    },
    "tissue": {
        "preset": Key("choice", '"slug"', "composition and parameter boxes to start from (docs/presets.md); the keys "
                      "below override its values", choices=tuple(PRESETS)),
        "directions": Key("rows", "the paper's three", "fibre directions, unit vectors within 1 % ([] for a "
                          "matrix-only material)"),
        "phi_fibres": Key("numbers", "[0.2, 0.2, 0.2]", "volume fraction of each fibre family"),
        "phi_matrix": Key("float", "0.4", "matrix volume fraction (with the fibres': 1)", low=0.0),
        "bulk_kpa": Key("float", "1000", "bulk modulus of the volumetric penalty (kPa)", **_POSITIVE),
        "eps0": Key("numbers", "zeros", "slack Green strain of each fibre family"),
        "second_branch": Key("numbers", "[]", "families (1-based) given a second Kelvin branch: a two-time-constant "
                             "fibre (bayestissue/mechanics/branches.py); family n_f + j is the j-th listed family's "
                             "second branch"),
        "matrix": Key("choice", '"mooney_rivlin"', "the matrix law (docs/laws.md)", choices=tuple(MATRIX_LAWS)),
        "terms": Key("int", "1", "Ogden terms (matrix = \"ogden\")", low=1),
        "fibre": Key("choice", '"linear"', "the fibre law (docs/laws.md)", choices=tuple(FIBRE_LAWS)),
        "recruitment": Key("bool", "false", "a recruitment stretch parameter (fibre = \"hgo\"): the toe region"),
        "matrix_branches": Key("int", "0", "Prony branches of the matrix (0: elastic)", low=0),
        "fibre_branches": Key("int", "1", "Prony branches of each fibre family (1: the paper's Kelvin fibre; 0: "
                              "elastic)", low=0),
    },
}  # fmt: skip


def check_experiment_document(doc: Mapping, file: str) -> None:
    """Check a parsed experiment file's tables, keys and value types; ``file`` names it in the messages.

    Raises
    ------
    ValidationError
        ``<file> [<table>] <key>: expected ..., got ...``; an unknown key or table is named with the nearest valid
        one.
    """
    tables = [t for t in TABLES if t]
    top = {k: v for k, v in doc.items() if not isinstance(v, Mapping)}
    check_known_keys(f"{file} top-level key", top, [*TABLES[""], *tables])
    for name in tables:  # a table name given a plain value (tissue = 5)
        if name in top:
            raise ValidationError(f"{file} [{name}]", top[name], f"a [{name}] table of key = value entries")
    check_table({k: v for k, v in top.items() if k in TABLES[""]}, TABLES[""], f"{file} top-level")
    for name, table in doc.items():
        if not isinstance(table, Mapping):
            continue
        check_known_keys(f"{file} table", {f"[{name}]": None}, [f"[{t}]" for t in tables])
        allowed = PROTOCOL_KEYS.get(table.get("kind")) if name == "protocol" else None
        check_table(table, TABLES[name], f"{file} [{name}]", allowed=allowed)


def experiment_markdown() -> str:
    """The experiment file reference (``docs/experiment.md``), rendered from :data:`TABLES`."""
    per_kind = "; ".join(f"{kind}: {', '.join(keys[1:]) or 'none'}" for kind, keys in PROTOCOL_KEYS.items())
    lines = [
        "# Experiment file reference",
        "",
        "<!-- Generated from bayestissue/mechanics/experiment_schema.py (experiment_markdown); "
        "tests/mechanics/test_experiment_schema.py keeps it equal. -->",
        "",
        "An experiment is a TOML file (e.g. `data/T1.toml`) and, usually, a CSV data file beside it. Unknown tables "
        "and keys (with the nearest valid name), values of the wrong type and out of range are refused with the "
        "file, the key, the value and what was expected (exit status 2). A `[protocol]` takes the keys of its kind "
        f"only ({per_kind}).",
        "",
        "The data file: comment lines `# key: value` (kept as metadata; `noise_sd_mm` is the known noise sd of a "
        "synthetic replica), a header row, then one row per time, comma-separated, decimal points; UTF-8 (with or "
        "without a byte-order mark) or UTF-16 with its mark. Columns: `time_s` (required, strictly increasing, "
        ">= 0), `displacement_mm` (the displacement of the loaded face: observed under force control, the load of a "
        "measured_stretch protocol without a stretch column), `force_mN` (the force on the loaded face: the load "
        "of a measured protocol, observed under stretch control), `stretch` (the load of a measured_stretch "
        "protocol), `nominal_stress_kpa` (observed under stretch control where the data give no force); for the "
        "second loaded face of a biaxial test `force_2_mN`, `nominal_stress_2_kpa`, `displacement_2_mm` and "
        "`stretch_2` or `force_2_mN` as its own load history (tests whose two loads are not proportional); for "
        "simple "
        "shear `shear` (the load of a measured_shear protocol) and `shear_stress_kpa` or `shear_force_mN` "
        "(observed).",
    ]
    for table, keys in TABLES.items():
        lines += ["", "## top level" if not table else f"## [{table}]", "", *reference_rows(keys)]
    return "\n".join(lines) + "\n"
