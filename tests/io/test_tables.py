"""The CSV reader's two paths (C parser for all-numeric tables, row reader otherwise) agree, and what both refuse."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.io.tables import read_table, write_table

TEXT = "# synthetic: yes\n# noise_sd_mm: 0.02\ntime_s,u_mm\n0,0\n3,0.25\n\n# a note among the rows\n6,1e-3\n"


def test_numeric_fast_path_equals_the_row_reader(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text(TEXT)
    fast, meta = read_table(p, numeric=True)  # every column numeric: numpy.loadtxt
    slow, _ = read_table(p, numeric=False)  # the row reader
    assert meta == {"synthetic": "yes", "noise_sd_mm": "0.02"}
    for name in ("time_s", "u_mm"):
        np.testing.assert_array_equal(fast[name], slow[name])
    np.testing.assert_array_equal(fast["u_mm"], [0.0, 0.25, 1e-3])  # the comment line among rows is skipped


@pytest.mark.parametrize("cell", ["nan", "inf", "-Infinity", "1_000", "", "0,5"])
def test_non_numbers_are_refused_with_line_and_column(tmp_path, cell):
    p = tmp_path / "t.csv"
    p.write_text(TEXT.replace("3,0.25", f"3,{cell}"))
    with pytest.raises(ValidationError, match=r"t.csv line 5"):
        read_table(p, numeric=True)


def test_text_columns_allowed_where_asked(tmp_path):
    p = tmp_path / "s.csv"
    write_table(p, {"parameter": np.array(["mu", "kappa"]), "median": np.array([2.5, 3.0])})
    cols, _ = read_table(p, numeric=("median",))
    assert cols["parameter"].tolist() == ["mu", "kappa"] and cols["median"].tolist() == [2.5, 3.0]
    with pytest.raises(ValidationError, match=r"s.csv line 2 column parameter: expected a finite number"):
        read_table(p, numeric=True)


def test_default_reads_text_and_nan_columns(tmp_path):
    """Without ``numeric`` (summary tables, benchmarks/compare_engines.py) a text column stays text and a number
    column with "nan" cells stays a number column."""
    p = tmp_path / "s.csv"
    p.write_text("parameter,median,wald_lower_90\nmu,2.5,nan\nkappa,3.0,1.5\n")
    cols, _ = read_table(p)
    assert cols["parameter"].tolist() == ["mu", "kappa"]
    assert cols["median"].tolist() == [2.5, 3.0]
    assert np.isnan(cols["wald_lower_90"][0]) and cols["wald_lower_90"][1] == 1.5


def test_header_only_and_empty_files(tmp_path):
    p = tmp_path / "h.csv"
    p.write_text("# only a comment\ntime_s,u_mm\n")
    with pytest.raises(ValidationError, match="h.csv: expected a header row and data rows, got 'a header without"):
        read_table(p)
    p.write_text("# only a comment\n")
    with pytest.raises(ValidationError, match="h.csv: expected a header row and data rows, got 'an empty table'"):
        read_table(p)


def test_numeric_write_round_trip(tmp_path):
    """Numeric tables are written by savetxt with the same cell format as the row writer ("%.10g")."""
    p = tmp_path / "w.csv"
    x = np.array([0.0, 1.0 / 3.0, 12345678901.0, -2e-12])
    write_table(p, {"a": x, "n": np.arange(4)}, meta={"k": "v"})
    assert p.read_text().splitlines()[:3] == ["# k: v", "a,n", "0,0"]
    cols, meta = read_table(p)
    np.testing.assert_allclose(cols["a"], x, rtol=1e-9)
    assert cols["n"].tolist() == [0, 1, 2, 3] and meta == {"k": "v"}
