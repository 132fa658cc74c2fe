"""The micrograph validation stage (studies/micrograph_validation.py) end to end on its quick phantom: it writes
the figures and a seed table whose every row has all its columns and whose counts cover every target."""

import re
from pathlib import Path

import pytest

from tests.study_module import load_study

ROOT = Path(__file__).resolve().parents[2]


def _cells(row: str) -> list[str]:
    """The cells of a Markdown table row (a pipe escaped as \\| belongs to its cell)."""
    return re.split(r"(?<!\\)\|", row.strip())[1:-1]


@pytest.mark.slow
def test_quick_validation_stage_writes_its_table_and_figures(tmp_path):
    module = load_study("micrograph_validation")
    module.main(["--quick", "--out", str(tmp_path)])
    text = (tmp_path / "micrographs_validation.md").read_text()
    for png in ("micrographs_validation.png", "micrographs_overlay.png"):
        assert (tmp_path / png).stat().st_size > 50_000
    header = next(line for line in text.splitlines() if line.startswith("| phantom | seed |"))
    rows = [line for line in text.splitlines() if line.startswith(("| default |", "| overlap (old) |"))]
    assert len(rows) == 2 and all(len(_cells(r)) == len(_cells(header)) == 12 for r in rows)
    assert "without the background (deg)" in header
    for name in ("default", "overlap (old)"):
        counts = next(line for line in text.splitlines() if line.startswith(f"- {name}: registration < 1 px: "))
        targets = [part.rsplit(": ", 1) for part in counts.removeprefix(f"- {name}: ").split("; ")]
        assert [t for t, _ in targets] == [
            "registration < 1 px",
            "V_V within 2 CE + |segmentation error|",
            "directions within 10 deg",
            "L_V within 15 %",
        ]
        assert all(c in ("0/1", "1/1") for _, c in targets)
    assert "largest direction error per seed with it default [" in text
