"""The T1-vs-T2 controls: pairs from one tissue with a planted cause, and the fixed decision rules."""

from pathlib import Path

import numpy as np
import pytest

from bayestissue.analyses import controls as ctl
from bayestissue.mechanics import load_experiment, simulate

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture(scope="module")
def templates():
    return load_experiment(DATA / "T1.toml"), load_experiment(DATA / "T2.toml")


def test_pairs_share_one_tissue_and_one_noise_stream(templates):
    """At one seed the planted cause is the only difference between scenarios: the T1 data of the negative control
    and of a T2 stiffness scale are identical, and their T2 data differ by exactly the noise-free difference."""
    t1, t2 = templates
    none = ctl.Scenario("none", ())
    stiff = ctl.Scenario("stiff", (3,), scale=1.5)
    a0, b0 = ctl.make_pair(t1, t2, none, 3)
    a3, b3 = ctl.make_pair(t1, t2, stiff, 3)
    np.testing.assert_array_equal(a0.displacement_mm, a3.displacement_mm)
    p = np.array(ctl.BASE_PARAMETERS)
    q = p.copy()
    q[[0, 1, 2, 5, 8]] *= 1.5
    clean = simulate(t2, q) - simulate(t2, p)
    np.testing.assert_allclose((b3.displacement_mm - b0.displacement_mm)[1:], clean[1:], atol=1e-12)
    assert a0.synthetic and a0.meta["synthetic"].startswith("yes") and a0.noise_sd_mm == ctl.NOISE_SD_MM
    assert a0.description.startswith("SYNTHETIC")
    # the fibre-law scenario changes both tests the same way: its T1 is not the base T1
    a1, _ = ctl.make_pair(t1, t2, ctl.Scenario("law", (1,), fast_branch=(2.0, 0.7, 0.005)), 3)
    assert np.max(np.abs(a1.displacement_mm - a0.displacement_mm)) > 0.05


@pytest.mark.slow
def test_negative_control_and_a_planted_stiffness(templates):
    """End to end on one seed: the negative control is not called a difference; a 1.5 x stiffer T2 is, and the
    stiffness scale is among the named causes, estimated within 1 % (noise 0.02 mm against a ~1 mm response)."""
    t1, t2 = templates
    v0 = ctl.pair_verdict(ctl.run_case(ctl.SCENARIOS[0], 11, t1, t2)["fit"])
    assert not v0.different
    assert set(v0.causes) == {"1", "2", "3"}  # no difference: the pair models are never fitted
    r3 = ctl.run_case(ctl.Scenario("stiff", (3,), scale=1.5), 11, t1, t2)
    v3 = ctl.pair_verdict(r3["fit"])
    assert v3.different and 3 in v3.named
    assert r3["fit"]["scale"] == pytest.approx(1.5, rel=0.01)
