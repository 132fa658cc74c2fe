"""What a checkpoint directory holds, read before any work: how far each run got, and which file is unreadable.

The emcee engine stores ensemble ``k`` in ``ensemble_<k>.h5`` (group ``ensemble_<k>``, emcee's ``HDFBackend``,
whose ``iteration`` attribute counts the stored steps); the nested engine stores run ``k`` in ``nested_<k>.h5``
(nautilus' own file, group ``sampler`` with the attribute ``n_like``, the likelihood evaluations so far), or,
with UltraNest, in the directory ``nested_<k>/`` (its log directory: ``results/points.hdf5`` with the attribute
``ncalls``).
"""

from __future__ import annotations

from pathlib import Path

from bayestissue._validation import ValidationError

__all__ = ["checkpoint_path", "stored_progress"]

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
    import h5py

    _, group, attr, unit = _LAYOUT[engine]
    done = []
    for k in range(n_runs):
        path = checkpoint_path(directory, engine, k)
        where, count = group.format(k=k), attr
        if engine == "nested" and not path.exists():  # an UltraNest run's log directory
            path, where, count = path.with_suffix("") / "results" / "points.hdf5", "/", "ncalls"
        if not path.exists():
            done.append(0)
            continue
        try:
            with h5py.File(path, "r") as f:
                g = f.get(where)
                done.append(0 if g is None else int(g.attrs.get(count, 0)))
        except (OSError, KeyError, ValueError) as exc:
            raise ValidationError(
                f"checkpoint {path}",
                f"unreadable ({type(exc).__name__}: {str(exc).splitlines()[0][:80]})",
                "an HDF5 checkpoint written by this tool",
                "a crash cut it short: delete this file to restart only this run, or start over with --overwrite",
            ) from None
    return done, unit
