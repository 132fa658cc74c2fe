"""What a checkpoint directory holds, read before any work: how far each run got, and which file is unreadable.

The emcee engine stores ensemble ``k`` in ``ensemble_<k>.h5`` (group ``ensemble_<k>``, emcee's ``HDFBackend``,
whose ``iteration`` attribute counts the stored steps); the nested engine stores run ``k`` in ``nested_<k>.h5``
(nautilus' own file, group ``sampler`` with the attribute ``n_like``, the likelihood evaluations so far), or,
with UltraNest, in the directory ``nested_<k>/`` (its log directory: ``results/points.hdf5`` with the attribute
``ncalls``).

Beside a nested run's checkpoint, ``nested_<k>.cost.json`` is its cost ledger: the likelihood evaluations, failed
forward solves and seconds of every process that worked on the run, rewritten at each progress report and at the
end, so that a run resumed over several sessions reports its whole cost, not only its last session's
(:func:`earlier_cost`).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

from bayestissue._validation import ValidationError

__all__ = ["RunCost", "checkpoint_path", "cost_meter", "earlier_cost", "stored_progress", "write_cost"]

#: engine -> (file stem, HDF5 group of run k, attribute counting its progress, unit of that count)
_LAYOUT = {
    "emcee": ("ensemble", "ensemble_{k}", "iteration", "steps"),
    "nested": ("nested", "sampler", "n_like", "evaluations"),
}


def checkpoint_path(directory: str | Path, engine: str, k: int) -> Path:
    """The checkpoint file of run ``k`` of ``engine`` in ``directory``."""
    return Path(directory) / f"{_LAYOUT[engine][0]}_{k}.h5"


def stored_progress(directory: str | Path, engine: str, n_runs: int) -> tuple[list[int], str]:
    """Progress checkpointed by each of ``n_runs`` runs (0 where nothing is stored) and its unit.

    Raises
    ------
    ValidationError
        Naming the first checkpoint that exists but cannot be read (truncated by a crash, 0 bytes, not HDF5), with
        the way out.
    """
    return [_stored(checkpoint_path(directory, engine, k), engine, k) for k in range(n_runs)], _LAYOUT[engine][3]


def _stored(path: Path, engine: str, k: int) -> int:
    """The progress stored at run ``k``'s checkpoint ``path`` (:func:`checkpoint_path`), 0 where there is none."""
    import h5py

    _, group, attr, _ = _LAYOUT[engine]
    where, count = group.format(k=k), attr
    if engine == "nested" and not path.exists():  # an UltraNest run's log directory
        path, where, count = path.with_suffix("") / "results" / "points.hdf5", "/", "ncalls"
    if not path.exists():
        return 0
    try:
        with h5py.File(path, "r") as f:
            g = f.get(where)
            return 0 if g is None else int(g.attrs.get(count, 0))
    except (OSError, KeyError, ValueError) as exc:
        raise ValidationError(
            f"checkpoint {path}",
            f"unreadable ({type(exc).__name__}: {str(exc).splitlines()[0][:80]})",
            "an HDF5 checkpoint written by this tool",
            "a crash cut it short: delete this file to restart only this run, or start over with --overwrite",
        ) from None


@dataclass(frozen=True)
class RunCost:
    """A nested run's cost so far: likelihood evaluations, failed forward solves, seconds (NaN: not recorded)."""

    calls: int = 0
    failed: int = 0
    seconds: float = 0.0

    def plus(self, calls: int, failed: int, seconds: float) -> RunCost:
        return RunCost(self.calls + int(calls), self.failed + int(failed), self.seconds + float(seconds))


def _ledger(path: Path) -> Path:
    return Path(path).with_suffix(".cost.json")


def earlier_cost(path: str | Path | None, resume: bool) -> RunCost:
    """What the processes before this one spent on nested run ``path`` (``nested_<k>.h5``, :func:`checkpoint_path`):
    nothing for a fresh run; for a resumed one the evaluations its checkpoint holds (the sampler's own count, read
    from the checkpoint itself, so exact where the ledger lags by up to one progress report) and the failed solves
    and seconds of its ledger. A checkpoint written before the ledger existed gives seconds NaN (not recorded) and
    no failed solves."""
    if path is None or not resume:
        return RunCost()
    path = Path(path)
    calls = _stored(path, "nested", int(path.stem.rsplit("_", 1)[1]))
    if calls == 0:
        return RunCost()
    try:
        ledger = json.loads(_ledger(path).read_text())
        return RunCost(calls, int(ledger["failed"]), float(ledger["seconds"]))
    except (OSError, ValueError, KeyError, TypeError):
        return RunCost(calls, 0, float("nan"))


def cost_meter(before: RunCost, problem) -> Callable[[], RunCost]:
    """A function giving ``before`` plus what ``problem`` has evaluated and failed, and the seconds, since this call:
    a run's cost over all its sessions at any moment of this one."""
    n_eval0, n_fail0, t0 = problem.n_evaluations, problem.n_failed, time.perf_counter()

    def cost() -> RunCost:
        return before.plus(problem.n_evaluations - n_eval0, problem.n_failed - n_fail0, time.perf_counter() - t0)

    return cost


def write_cost(path: str | Path | None, cost: RunCost) -> None:
    """Store ``cost`` as run ``path``'s ledger (written whole, then renamed: a killed write leaves the old one)."""
    if path is None:
        return
    ledger = _ledger(Path(path))
    tmp = ledger.with_suffix(".tmp")
    tmp.write_text(json.dumps(asdict(cost)))
    os.replace(tmp, ledger)
