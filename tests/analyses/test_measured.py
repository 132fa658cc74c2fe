"""The real-data study's pieces: the bundled measured curves, range trimming, the closed-form incompressible
Mooney-Rivlin fit."""

from pathlib import Path

import numpy as np

from bayestissue.analyses.measured import CASES, incompressible_fit, incompressible_stress, trimmed
from bayestissue.io.tables import read_table
from bayestissue.mechanics import load_experiment

DATA = Path(__file__).resolve().parents[2] / "data" / "measured"


def test_bundled_measured_files_say_what_they_are():
    """Each real curve says it is measured, names its publication and carries the licence notice; the loader reads
    it as a stretch-controlled, matrix-only experiment observing the nominal stress."""
    for case in CASES:
        exp = load_experiment(DATA / case.file)
        _, meta = read_table(Path(exp.data_file))
        assert meta["measured"].startswith("yes")
        assert "synthetic" not in meta and not exp.synthetic
        assert "Copyright (c) 2024 Chongran Zhao" in meta["licence"]
        assert "permission notice shall be included" in meta["licence text"]
        assert exp.controls == "stretch" and exp.tissue.n_fibres == 0
        assert exp.observable[:2] == ("nominal stress", "kPa")
        assert np.all(np.diff(exp.protocol.stretch) > 0) and exp.protocol.stretch[0] > 1.0


def test_trimmed_keeps_the_range():
    exp = load_experiment(DATA / "treloar_1944.toml")
    cut = trimmed(exp, 3.0)
    assert cut.protocol.stretch.max() <= 3.0 < exp.protocol.stretch.max()
    assert cut.time_s.size == cut.observed.size == 8 and exp.time_s.size == 24
    np.testing.assert_array_equal(cut.observed, exp.observed[:8])
    assert trimmed(exp, np.inf) is exp


def test_incompressible_fit_recovers_exact_constants():
    lam = np.linspace(1.02, 3.0, 12)
    mu, kappa, rms = incompressible_fit(lam, incompressible_stress(lam, 210.0, -35.0))
    assert abs(mu - 210.0) < 1e-9 and abs(kappa + 35.0) < 1e-9 and rms < 1e-9
