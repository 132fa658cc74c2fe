"""Same input, same bits: whether the numba kernels are compiled in the process (cold cache) or loaded from
numba's on-disk cache (warm) must not change a simulation. With fast-math the two differed in the last bits
(cross-function inlining and reassociation depend on what was cached), which the sloppy least-squares problems
amplified into different optima; see bayestissue/mechanics/_jit.py."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

_SCRIPT = """
import hashlib
import numpy as np
from bayestissue.mechanics import load_experiment, simulate
from bayestissue.paper import PAPER_PARAMETERS
exp = load_experiment("data/T1.toml")
p = np.array(PAPER_PARAMETERS["initial"], dtype=float)
batch = p * (1 + 1e-4 * np.vstack([np.zeros(11), np.eye(11)]))
out = np.concatenate([simulate(exp, p).ravel(), simulate(exp, batch).ravel()])
print(hashlib.sha256(out.tobytes()).hexdigest())
"""


def _run(cache_dir):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", _SCRIPT], cwd=ROOT, env=env, capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_cold_and_warm_numba_cache_give_identical_bits(tmp_path):
    cold = _run(tmp_path)  # empty cache dir: everything compiled in this process
    warm = _run(tmp_path)  # the same kernels loaded from the cache written by the first run
    assert len(cold) == 64
    assert cold == warm
