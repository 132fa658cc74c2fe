"""The bundled synthetic stereology files are exactly what their generators make from the recorded seeds."""

from pathlib import Path

import numpy as np

from bayestissue.stereology import LineSystem, PointCounts
from bayestissue.stereology.replica import SMC_TARGET, TOTAL_LENGTH_UM, make_counts, make_lines

DATA = Path(__file__).resolve().parents[2] / "data"
SEED = 20140791  # data/README.md


def test_bundled_counts_are_the_generator_output_and_within_one_ce_of_the_paper():
    cnt, used = make_counts(SEED)
    stored = PointCounts.from_file(DATA / "stereology_counts.csv")
    np.testing.assert_array_equal(stored.section, cnt["section"])
    np.testing.assert_array_equal(stored.counts, cnt["counts"])
    assert f"# seed: {used}" in (DATA / "stereology_counts.csv").read_text().splitlines()
    assert abs(cnt["vv"] - SMC_TARGET) <= cnt["ce"] * cnt["vv"]  # the seed rule


def test_bundled_lines_are_the_generator_output_with_the_paper_total_length():
    ln = make_lines(SEED + 1)
    stored = LineSystem.from_file(DATA / "stereology_lines.csv")
    # the file stores coordinates rounded to its printed precision
    np.testing.assert_allclose(stored.start, ln["start"], atol=1e-3)
    np.testing.assert_allclose(stored.end, ln["end"], atol=1e-3)
    assert abs(stored.total_length_um - TOTAL_LENGTH_UM) < 0.05
