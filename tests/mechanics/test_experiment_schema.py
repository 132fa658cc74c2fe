"""The experiment file schema: the documentation is rendered from it, and every key's type is enforced."""

from pathlib import Path

import pytest

from bayestissue._validation import ValidationError
from bayestissue.mechanics.experiment_schema import TABLES, check_experiment_document, experiment_markdown

DOCS = Path(__file__).resolve().parents[2] / "docs" / "experiment.md"

GOOD = {
    "name": "T1",
    "synthetic": True,
    "specimen": {"length_x_mm": 5.33, "length_y_mm": 2.43, "length_z_mm": 3.9},
    "protocol": {"kind": "creep", "stress_kpa": 10.6},
    "simulation": {"dt_s": 6.0},
    "data": {"file": "T1.csv"},
    "tissue": {"directions": [[0, 1, 0]], "phi_fibres": [0.6], "phi_matrix": 0.4, "bulk_kpa": 1000, "eps0": [0]},
}


def test_reference_is_rendered_from_the_schema():
    assert DOCS.read_text() == experiment_markdown(), "regenerate docs/experiment.md from experiment_markdown()"
    for table, keys in TABLES.items():
        for key in keys:
            assert f"| `{key}` |" in DOCS.read_text(), (table, key)


def test_a_complete_file_passes():
    check_experiment_document(GOOD, "T1.toml")


def _with(table, key, value):
    doc = {k: (dict(v) if isinstance(v, dict) else v) for k, v in GOOD.items()}
    (doc if table is None else doc[table])[key] = value
    return doc


@pytest.mark.parametrize(
    ("table", "key", "value", "match"),
    [
        (None, "synthetic", "yes", r"T1.toml top-level synthetic: expected true or false, got 'yes'"),
        (None, "nmae", "T1", r"top-level key: .*got 'nmae' \(did you mean 'name'\?\)"),
        ("specimen", "length_x_mm", True, r"\[specimen\] length_x_mm: expected a number > 0, got True"),
        ("specimen", "length_y_mm", -1.0, r"\[specimen\] length_y_mm: expected a number > 0, got -1.0"),
        ("simulation", "dt_s", "6", r"\[simulation\] dt_s: expected a number > 0, got '6'"),
        (
            "protocol",
            "kind",
            "relax",
            r"\[protocol\] kind: expected one of \['creep', 'ramp', 'measured', 'stretch_ramp'",
        ),
        (
            "protocol",
            "hold_s",
            5.0,
            r"\[protocol\] key: expected one of \['kind', 'mode', 'ratio', 'stress_kpa'\], got 'hold_s'",
        ),
        (
            "tissue",
            "directions",
            [[0, "y", 0]],
            r"\[tissue\] directions row 1: expected finite numbers, got \[0, .y., 0\]",
        ),
        ("tissue", "phi_fibres", 0.6, r"\[tissue\] phi_fibres: expected a list of numbers, got 0.6"),
        ("data", "file", 3, r"\[data\] file: expected a string, got 3"),
    ],
)
def test_wrong_values_and_keys_are_named(table, key, value, match):
    with pytest.raises(ValidationError, match=match):
        check_experiment_document(_with(table, key, value), "T1.toml")


def test_unknown_table_is_named_with_the_nearest():
    doc = dict(GOOD, simulaton={"dt_s": 6.0})
    with pytest.raises(ValidationError, match=r"T1.toml table: .*got '\[simulaton\]' \(did you mean '\[simulation\]'"):
        check_experiment_document(doc, "T1.toml")
