"""A short creep test through the real forward model with a known truth: the paper's T1 protocol cut at 120 s, its
displacement simulated at the paper's T1 parameters (beta2 = beta3 = 0.02 1/s, so the curve relaxes within the test)
plus Gaussian noise of sd 0.01 mm. Used where a test needs a real calibration that samples in seconds."""

from dataclasses import replace
from pathlib import Path

import numpy as np

from bayestissue.mechanics import ForwardModel, load_experiment

T1 = Path(__file__).resolve().parents[1] / "data" / "T1.toml"
TRUTH = [2.18, 2.91, 125, 0.75, 1.25, 13.4, 0.891, 0.02, 13.4, 0.891, 0.02]
SD = 0.01


def short_creep():
    e = load_experiment(T1)
    keep = e.time_s <= 120.0
    e = replace(e, time_s=e.time_s[keep], displacement_mm=None, force_mN=None)
    y = ForwardModel(e)(np.asarray(TRUTH, float)[None])[0]
    return replace(e, displacement_mm=y + SD * np.random.default_rng(5).standard_normal(y.size), meta={})


def short_creep_config(**over):
    """Its calibration: mu and ginf2 sampled in a box around the truth, the rest held at the truth, the mirror ties,
    the noise sd known; ``over`` as :func:`bayestissue.workflows.load_config` takes it."""
    from bayestissue.workflows import load_config

    names = ("mu", "kappa", "ginf1", "gamma1", "beta1", "ginf2", "gamma2", "beta2")
    return load_config(
        None,
        sampled=["mu", "ginf2"],
        bounds={"mu": [0.5, 5.0], "ginf2": [5.0, 50.0]},
        tied={"ginf3": "ginf2", "gamma3": "gamma2", "beta3": "beta2"},
        initial=dict(zip(names, TRUTH, strict=False)),
        noise_options={"sd": SD},
        **over,
    )
