"""The run directory as a unit (issue 19): the lock, the manifest and what a resume or a fresh run accepts."""

import json
import os
import subprocess
import sys

import pytest

from bayestissue._validation import ValidationError
from bayestissue.workflows.run_directory import (
    MANIFEST,
    manifest_differences,
    open_run_directory,
)


def _manifest(**config):
    base = {"seed": 1, "prior": "default", "sampler": {"max_steps": 100, "moves": "de_snooker"}}
    base.update(config)
    return {
        "package_sha256": "abc",
        "bayestissue_version": "0.1.0",
        "engine": "emcee",
        "seed": base["seed"],
        "config": base,
        "inputs": [
            {"experiment": "T1", "file": "T1.toml", "file_sha256": "1", "data_file": "T1.csv", "data_file_sha256": "2"}
        ],
    }


def test_manifest_differences_name_what_changed_and_allow_a_longer_run():
    old = _manifest()
    assert manifest_differences(old, _manifest()) == []
    assert manifest_differences(old, _manifest(sampler={"max_steps": 5000, "moves": "de_snooker"})) == []
    assert manifest_differences(old, _manifest(seed=2)) == ["seed 1 -> 2"]
    # a finished emcee sample may be cross-checked on resume (it does not change what the ensembles sample)
    assert manifest_differences(_manifest(cross_check="none"), _manifest(cross_check="nested")) == []
    assert manifest_differences(old, _manifest(sampler={"max_steps": 100, "moves": "mixture"})) == [
        "sampler.moves 'de_snooker' -> 'mixture'"
    ]
    new = _manifest()
    new["inputs"][0]["data_file_sha256"] = "3"
    assert manifest_differences(old, new) == ["T1's data file T1.csv -> T1.csv (content changed)"]
    new = _manifest()
    new["inputs"][0]["experiment"] = "T2"
    assert manifest_differences(old, new) == ["experiments ['T1'] -> ['T2']"]
    new = _manifest()
    new["package_sha256"] = "def"
    assert manifest_differences(old, new)[0].startswith("the code")


def test_status_lock_and_refusals(tmp_path):
    out = tmp_path / "run"
    with open_run_directory(out, _manifest()) as run:
        assert json.loads((out / MANIFEST).read_text())["status"] == "running"
        # a second opener (here in another process, as a second `fit` would be) is refused with our pid
        code = (
            "import sys; from bayestissue.workflows.run_directory import open_run_directory as o\n"
            "try:\n    o(sys.argv[1], {}, resume=True).__enter__()\nexcept ValueError as e:\n    print(e)\n"
        )
        msg = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True).stdout
        assert f"in use by pid {os.getpid()}" in msg, msg
        (run.checkpoints).mkdir()
    assert json.loads((out / MANIFEST).read_text())["status"] == "finished"
    with pytest.raises(ValidationError, match=r"--out: expected an empty or new directory.*--overwrite replaces it"):
        open_run_directory(out, _manifest()).__enter__()
    with pytest.raises(ValidationError, match=r"--resume: .*\(seed 1 -> 7\)"):
        open_run_directory(out, _manifest(seed=7), resume=True).__enter__()
    with pytest.raises(ValidationError, match="nothing to resume"):
        open_run_directory(tmp_path / "typo", _manifest(), resume=True).__enter__()
    assert not (tmp_path / "typo").exists()
    with open_run_directory(out, _manifest(), overwrite=True) as run:
        assert not run.checkpoints.exists() and any("--overwrite" in n for n in run.notes)


def test_failure_is_recorded_and_bad_input_leaves_nothing(tmp_path):
    out = tmp_path / "run"
    with pytest.raises(RuntimeError), open_run_directory(out, _manifest()) as run:
        run.checkpoints.mkdir()
        raise RuntimeError("solver exploded")
    stored = json.loads((out / MANIFEST).read_text())
    assert stored["status"] == "failed" and "solver exploded" in stored["error"]
    fresh = tmp_path / "fresh"
    with pytest.raises(ValidationError), open_run_directory(fresh, _manifest()):
        raise ValidationError("n_walkers", 4, "an integer >= 26")
    assert not fresh.exists()


def test_interrupted_run_is_explained_and_corrupt_checkpoint_named(tmp_path):
    out = tmp_path / "run"
    # a run that dies holding the lock, its manifest still saying "running"
    code = (
        "import os, sys; from bayestissue.workflows.run_directory import open_run_directory as o\n"
        "cm = o(sys.argv[1], {'engine': 'emcee', 'config': {'sampler': {'n_ensembles': 2}}}); cm.__enter__(); "
        "os._exit(9)\n"
    )
    subprocess.run([sys.executable, "-c", code, str(out)], check=False)
    m = {"engine": "emcee", "config": {"sampler": {"n_ensembles": 2}}}
    with open_run_directory(out, m, resume=True) as run:
        assert any("was interrupted before it finished" in n for n in run.notes), run.notes
        assert run.resumed == [0, 0] and run.unit == "steps"
        run.checkpoints.mkdir()
        (run.checkpoints / "ensemble_1.h5").write_bytes(b"")
    with pytest.raises(ValidationError, match=r"checkpoint .*ensemble_1.h5: .*delete this file .* --overwrite"):
        open_run_directory(out, m, resume=True).__enter__()


def test_resume_with_checkpoints_that_are_a_file_is_refused(tmp_path):
    out = tmp_path / "run"
    m = {"engine": "emcee", "config": {"sampler": {"n_ensembles": 2}}}
    with open_run_directory(out, m):
        pass
    (out / "checkpoints").write_text("not a folder")
    with pytest.raises(ValidationError, match=r"--resume: expected a folder of checkpoints \(checkpoints/ is a file\)"):
        open_run_directory(out, m, resume=True).__enter__()


def test_the_manifest_hashes_the_code_the_numbers_come_from_and_not_the_report(tmp_path):
    """A resume survives a change of the report, the figures or the command line (a lab may update the tool for a
    figure while a long run is checkpointed) and is refused after a change of the mechanics, the samplers, the
    workflow or the readers: :data:`~bayestissue.io.results.RUN_SOURCES` (checked on a copy of the package)."""
    import shutil
    from pathlib import Path

    import bayestissue
    from bayestissue.io.results import RUN_SOURCES, package_sha256

    pkg = tmp_path / "bayestissue"
    shutil.copytree(Path(bayestissue.__file__).parent, pkg, ignore=shutil.ignore_patterns("__pycache__"))
    before, whole = package_sha256(pkg), package_sha256(pkg, parts=None)
    for part in ("report/render.py", "plotting/style.py", "cli/__init__.py"):
        (pkg / part).write_text((pkg / part).read_text() + "\n# edited\n")
    assert package_sha256(pkg) == before and package_sha256(pkg, parts=None) != whole
    for part in RUN_SOURCES:
        f = pkg / part if part.endswith(".py") else sorted((pkg / part).rglob("*.py"))[-1]
        saved = f.read_bytes()
        f.write_bytes(saved + b"\n# edited\n")
        assert package_sha256(pkg) != before, part
        f.write_bytes(saved)
    assert package_sha256(pkg) == before
