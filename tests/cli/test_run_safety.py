"""`bayestissue fit` and its run directory (issue 19): resumes that check what they resume, no second run on a busy
directory, no orphaned workers after `kill -9`, provenance of the files actually read."""

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bayestissue.cli import main
from bayestissue.io.results import read_inference_data

DATA = Path(__file__).resolve().parents[2] / "data"
SMALL = '[parameters]\nsampled = ["mu", "kappa"]\n[warmstart]\nn_starts = 1\n[sampler]\nn_ensembles = 2\n'


def _fit(tmp_path, experiment, out, *extra, config=SMALL):
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(config)
    args = ["fit", str(experiment), "--config", str(cfg), "--out", str(out), "--quick", "--no-figures"]
    return main([*args, "--no-progress", *extra])


def _digest(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def test_resume_checks_what_it_resumes(tmp_path, capsys):
    out = tmp_path / "run"
    assert _fit(tmp_path, DATA / "T2.toml", out) == 0
    before = _digest(out / "checkpoints" / "ensemble_0.h5")
    capsys.readouterr()
    # another experiment on the stored run: refused before any work, the stored chain untouched
    assert _fit(tmp_path, DATA / "T1.toml", out, "--resume") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "experiments ['T2'] -> ['T1']" in err, err
    assert _digest(out / "checkpoints" / "ensemble_0.h5") == before
    # a changed seed or prior likewise, each named
    assert _fit(tmp_path, DATA / "T2.toml", out, "--resume", "--seed", "3") == 2
    assert "seed 20261121 -> 3" in capsys.readouterr().err
    uniform = SMALL.replace("[parameters]\n", '[parameters]\nprior = "uniform"\n')
    assert _fit(tmp_path, DATA / "T2.toml", out, "--resume", config=uniform) == 2
    assert "prior 'default' -> 'uniform'" in capsys.readouterr().err
    # the same run resumes and says where each ensemble stood
    assert _fit(tmp_path, DATA / "T2.toml", out, "--resume") == 0
    assert "ensemble 0 at 300 steps, ensemble 1 at 300 steps" in capsys.readouterr().out
    # a fresh run over it is refused; --overwrite replaces it
    assert _fit(tmp_path, DATA / "T2.toml", out) == 2
    assert "--resume continues that run, --overwrite replaces it" in capsys.readouterr().err
    assert _fit(tmp_path, DATA / "T2.toml", out, "--overwrite") == 0
    assert json.loads((out / "manifest.json").read_text())["status"] == "finished"


def test_corrupt_checkpoint_is_named_with_the_way_out(tmp_path, capsys):
    out = tmp_path / "run"
    assert _fit(tmp_path, DATA / "T2.toml", out) == 0
    ckpt = out / "checkpoints" / "ensemble_1.h5"
    ckpt.write_bytes(ckpt.read_bytes()[:2000])  # truncated, as by a crash mid-write
    capsys.readouterr()
    assert _fit(tmp_path, DATA / "T2.toml", out, "--resume") == 2
    err = capsys.readouterr().err
    assert "ensemble_1.h5" in err and "--overwrite" in err and "Traceback" not in err


def test_provenance_hashes_the_files_read(tmp_path):
    """The experiment reads measured_run7.csv; an unrelated T2.csv lies beside it and is not hashed."""
    shutil.copy(DATA / "T2.csv", tmp_path / "measured_run7.csv")
    (tmp_path / "T2.csv").write_text("unrelated\n")
    (tmp_path / "T2.toml").write_text((DATA / "T2.toml").read_text().replace('"T2.csv"', '"measured_run7.csv"'))
    out = tmp_path / "run"
    assert _fit(tmp_path, tmp_path / "T2.toml", out) == 0
    attrs = read_inference_data(out / "posterior.nc").posterior.attrs
    assert attrs["data_sha256:measured_run7.csv"] == _digest(tmp_path / "measured_run7.csv")
    assert "data_sha256:T2.csv" not in attrs
    inputs = json.loads((out / "manifest.json").read_text())["inputs"]
    assert inputs[0]["data_file_sha256"] == _digest(tmp_path / "measured_run7.csv")


def _children(pid):
    kids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            kids.append(int(stat.parent.name))
    return kids


def _alive(pid):
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc (Linux)")
def test_kill_9_leaves_no_workers_and_the_next_run_is_told(tmp_path, capsys):
    cfg = tmp_path / "long.toml"
    cfg.write_text(SMALL + "max_steps = 200000\nn_processes = 2\n")
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "bayestissue", "fit", str(DATA / "T2.toml"), "--config", str(cfg), "--out", str(out)]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen([*cmd, "--no-progress", "--no-figures"], env=env, stdout=subprocess.DEVNULL)
    try:
        deadline = time.time() + 120
        while time.time() < deadline and len(_children(proc.pid)) < 2:
            time.sleep(0.5)
        workers = _children(proc.pid)
        assert len(workers) >= 2, "the run did not start its worker processes"
        # a second run on the busy directory is refused with the holder's pid
        code = main(["fit", str(DATA / "T2.toml"), "--config", str(cfg), "--out", str(out), "--resume"])
        assert code == 2 and f"in use by pid {proc.pid}" in capsys.readouterr().err
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.time() + 20
        while time.time() < deadline and any(_alive(w) for w in workers):
            time.sleep(0.2)
        assert not any(_alive(w) for w in workers), "workers outlived the killed run"
    finally:
        if proc.poll() is None:
            proc.kill()
    # the next run is told, and resumes with a shorter cap (max_steps may change on a resume)
    cfg.write_text(SMALL + "max_steps = 300\nn_processes = 2\n")
    assert main([*cmd[3:], "--resume", "--no-progress", "--no-figures"]) == 0
    text = capsys.readouterr().out
    assert "was interrupted before it finished" in text and "resuming" in text
