"""The configuration schema: every kind of key accepted and refused by name; docs/config.md is its rendering."""

from __future__ import annotations

from pathlib import Path

import pytest

from bayestissue._validation import ValidationError
from bayestissue.inference.sampling import NestedOptions, SamplerOptions
from bayestissue.workflows import config_from_mapping
from bayestissue.workflows.schema import SCHEMA, check_mapping, config_markdown

ROOT = Path(__file__).resolve().parents[2]


def test_docs_config_md_is_the_rendered_schema():
    assert (ROOT / "docs" / "config.md").read_text() == config_markdown()


def test_every_sampler_option_is_in_the_schema_and_nothing_else():
    extra = {"seed", "sample", "coordinates", "engine", "cross_check"}  # calibration settings kept in [sampler]
    assert set(SCHEMA["sampler"]) - extra == set(SamplerOptions.__dataclass_fields__)
    assert set(SCHEMA["nested"]) == set(NestedOptions.__dataclass_fields__)


def test_documented_defaults_are_the_code_defaults():
    """The reference's default column for every key with a plain default equals the dataclass default."""
    from bayestissue.inference.likelihood import StudentTNoise
    from bayestissue.workflows import CalibrationConfig

    def text(v):
        if isinstance(v, bool):  # before the dict lookup: 0 == False and 1 == True as keys
            return "true" if v else "false"
        return f'"{v}"' if isinstance(v, str) else str(v)

    sampler = {n: f.default for n, f in SamplerOptions.__dataclass_fields__.items() if f.default is not None}
    nested = {n: f.default for n, f in NestedOptions.__dataclass_fields__.items() if f.default is not None}
    config = CalibrationConfig()
    plain = {
        **{("sampler", n): v for n, v in sampler.items()},
        **{("nested", n): v for n, v in nested.items()},
        ("sampler", "engine"): config.engine,
        ("sampler", "seed"): config.seed,
        ("sampler", "sample"): config.sample,
        ("sampler", "coordinates"): config.coordinates,
        ("sampler", "cross_check"): config.cross_check,
        ("warmstart", "n_starts"): config.n_starts,
        ("warmstart", "max_nfev"): config.ls_max_nfev,
        ("warmstart", "jacobian"): config.ls_jacobian,
        ("output", "max_draws"): config.max_draws,
        ("output", "n_predictive"): config.n_predictive,
        ("likelihood", "noise"): config.noise,
        ("likelihood", "nu"): StudentTNoise.nu,
        ("parameters", "prior"): config.prior,
    }
    for (section, name), value in plain.items():
        assert SCHEMA[section][name].default == text(value), (section, name)


GOOD = {
    "parameters": {
        "prior": "uniform",
        "fixed": {"ginf1": 125.0},
        "sampled": ["mu", "kappa", "ginf2"],
        "bounds": {"mu": [0.01, 100]},
        "priors": {"mu": "uniform"},
        "initial": {"mu": 5},
        "tied": {"ginf3": "ginf2"},
        "exchangeable": [["ginf2"], ["ginf3"]],
    },
    "likelihood": {"noise": "ar1", "sd": "data", "rho_bounds": [-0.5, 0.5]},
    "warmstart": {"n_starts": 0, "max_nfev": 10, "jacobian": "exact"},
    "sampler": {"seed": 0, "sample": False, "n_walkers": 40, "tau_factor": 30, "moves": "mixture", "engine": "nested"},
    "nested": {"n_live": 300, "n_runs": 6, "f_live": 0.05, "discard_exploration": False, "max_evaluations": 10**6},
    "output": {"max_draws": 100, "n_predictive": 0},
}


def test_a_config_with_every_kind_passes():
    check_mapping(GOOD)
    cfg = config_from_mapping({k: v for k, v in GOOD.items() if k != "parameters"})
    assert cfg.sampler.tau_factor == 30 and cfg.sample is False and cfg.noise_options["sd"] == "data"
    assert cfg.ls_jacobian == "exact"
    assert cfg.engine == "nested" and cfg.nested.n_live == 300 and cfg.nested.discard_exploration is False


@pytest.mark.parametrize(
    "section, key, value, expected",
    [
        ("parameters", "prior", "flat", r"one of \['default', 'uniform'\]"),
        ("parameters", "fixed", {"mu": "1"}, "a table name = value or a list of names"),
        ("parameters", "sampled", "mu", "a list of parameter names"),
        ("parameters", "initial", {"mu": True}, "a table name = value"),
        ("parameters", "exchangeable", [["ginf2"], ["ginf3", "gamma3"]], "two lists of parameter names of equal"),
        ("likelihood", "nu", 0, "a number > 0"),
        ("likelihood", "rho", float("nan"), "a number"),
        ("warmstart", "n_starts", -1, "an integer >= 0"),
        ("warmstart", "jacobian", "complex", "one of"),
        ("sampler", "n_walkers", 3, "an integer >= 4"),
        ("sampler", "moves", "hmc", "one of"),
        ("sampler", "engine", "mcmc", r"one of \['emcee', 'nested'\]"),
        ("nested", "n_live", 5, "an integer >= 10"),
        # sizes that exhausted memory or never finished (issue 34): an upper bound, just above and at it
        ("nested", "n_live", 10**12, "an integer >= 10 and <= 100000"),
        ("nested", "n_runs", 1001, "an integer >= 1 and <= 1000"),
        ("nested", "n_networks", 10**6, "an integer >= 1 and <= 64"),
        ("nested", "discard_exploration", "yes", "true or false"),
        ("nested", "network_tol", 0.5, "a number >= 0 and <= 0.1"),
        ("output", "max_draws", 0, "an integer >= 1"),
    ],
)
def test_bad_values_are_named_with_file_section_and_key(section, key, value, expected):
    with pytest.raises(ValidationError, match=rf"configuration fit.toml \[{section}\] {key}: expected {expected}"):
        check_mapping({section: {key: value}}, where="configuration fit.toml")


def test_unknown_sections_and_keys_are_refused_by_name():
    with pytest.raises(ValidationError, match=r"configuration section: expected one of \['parameters'"):
        check_mapping({"mcmc": {}})
    with pytest.raises(
        ValidationError, match=r"\[sampler\] key: expected one of .*got 'walkers' \(did you mean 'n_walkers'\?\)"
    ):
        check_mapping({"sampler": {"walkers": 3}})
    with pytest.raises(ValidationError, match=r"\[output\]: expected a table of key = value entries"):
        check_mapping({"output": 3})


def test_upper_bounds_are_inclusive_and_min_steps_at_most_max_steps():
    check_mapping({"nested": {"n_runs": 1000, "n_live": 100_000, "n_networks": 64}})
    check_mapping({"sampler": {"min_steps": 500, "max_steps": 500}})
    with pytest.raises(ValidationError, match=r"\[sampler\] min_steps: expected at most max_steps \(500\), got 501"):
        check_mapping({"sampler": {"min_steps": 501, "max_steps": 500}})
    with pytest.raises(ValidationError, match=r"min_steps: expected at most max_steps \(20000\)"):
        check_mapping({"sampler": {"min_steps": 20001}})
