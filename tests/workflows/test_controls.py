"""The T1-vs-T2 controls: pairs from one tissue with a planted cause, and the fixed decision rules."""

from pathlib import Path

import numpy as np
import pytest

from bayestissue.mechanics import load_experiment, simulate
from bayestissue.workflows import controls as ctl

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture(scope="module")
def templates():
    return load_experiment(DATA / "T1.toml"), load_experiment(DATA / "T2.toml")


def _fit(joint, law, angle, scale, pairs=None, t1=400.0, t2=140.0):
    """A fit result with chosen chi-square values; the pair models default to no better than their best single."""
    chi2 = {"T1": t1, "T2": t2, "joint": joint, "1": law, "2": angle, "3": scale}
    for key, (a, b) in (("1+2", ("1", "2")), ("1+3", ("1", "3")), ("2+3", ("2", "3"))):
        chi2[key] = (pairs or {}).get(key, min(chi2[a], chi2[b]))
    return {
        "chi2": chi2,
        "extra": {k: 3 * (1 in c) + (2 in c) + (3 in c) for k, c in ctl.MODELS.items()},
        "specimen": {k: (2 in c) + (3 in c) for k, c in ctl.MODELS.items()},
        "n": 544,
    }


def test_rules_on_chosen_numbers():
    """Each branch of the rules once; ln(544) = 6.3, so BIC needs a drop > 10 + 6.3 k; chi2_8 at p = 0.001 is 26.1,
    chi2_7 is 24.3, chi2_6 22.5."""
    v = ctl.verdict(_fit(565.0, 560.0, 560.0, 560.0))  # Q = 25 < 26.1
    assert not v["different"] and v["kind"] == "no difference" and v["named"] == ()
    v = ctl.verdict(_fit(640.0, 640.0, 550.0, 600.0))  # only the angle removes the tension
    assert v["different"] and v["kind"] == "named" and v["named"] == (2,)
    v = ctl.verdict(_fit(640.0, 640.0, 550.0, 555.0))  # angle and scale within 10 of each other
    assert v["kind"] == "indistinguishable" and v["named"] == (2, 3)
    v = ctl.verdict(_fit(9000.0, 8990.0, 600.0, 590.0))  # both help a lot, neither removes the tension
    assert v["kind"] == "partial" and v["named"] == (2, 3)
    v = ctl.verdict(_fit(640.0, 640.0, 635.0, 635.0))  # nothing helps
    assert v["kind"] == "unexplained" and v["named"] == ()
    v = ctl.verdict(_fit(600.0, 560.0, 600.0, 600.0))  # the richer law: drop 40 > 10 + 3 x 6.3 = 28.9
    assert v["named"] == (1,) and v["causes"]["1"]["delta_bic"] == pytest.approx(40 - 3 * np.log(544))
    # law + scale: the pair removes the tension and beats each single by BIC > 10
    v = ctl.verdict(_fit(9000.0, 8990.0, 9000.0, 600.0, pairs={"1+3": 545.0}))
    assert v["kind"] == "combination" and v["named"] == (1, 3) and v["models"] == ["1+3"]
    # a pair that is no better than its best single (by BIC) is not needed: partial
    v = ctl.verdict(_fit(9000.0, 8990.0, 9000.0, 600.0, pairs={"1+3": 590.0}))
    assert v["kind"] == "partial" and v["named"] == (3,)


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
    v0 = ctl.verdict(ctl.run_case(ctl.SCENARIOS[0], 11, t1, t2)["fit"])
    assert not v0["different"]
    assert set(v0["causes"]) == {"1", "2", "3"}  # no difference: the pair models are never fitted
    r3 = ctl.run_case(ctl.Scenario("stiff", (3,), scale=1.5), 11, t1, t2)
    v3 = ctl.verdict(r3["fit"])
    assert v3["different"] and 3 in v3["named"]
    assert r3["fit"]["scale"] == pytest.approx(1.5, rel=0.01)
