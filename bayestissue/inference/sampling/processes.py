"""Independent runs of one posterior in forked worker processes, progress coming back on a queue.

The ensembles of the emcee engine and the runs of the nested engine share this executor: the problem holds
numba-compiled forwards and need not pickle (the workers are forked and receive it at start-up), every run
reports its progress through a queue drained in the calling process, and without ``fork`` (or with one process)
the runs go one after another in this process.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import queue as _queue
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor

__all__ = ["run_in_processes"]

_WORKER: dict = {}


def _die_with_parent(parent: int) -> None:
    """End this worker when the process that forked it ends, however it ends (``kill -9`` included): a worker
    left behind would go on sampling, writing checkpoints and holding the run directory's lock.

    Linux: the kernel sends SIGKILL on the parent's death (``prctl(PR_SET_PDEATHSIG)``); elsewhere a daemon thread
    polls the parent pid every second. Either way the parent may already be gone when this runs: checked once.
    """
    import ctypes
    import signal
    import threading
    import time

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        armed = libc.prctl(pr_set_pdeathsig, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):
        armed = False
    if not armed:

        def watch():
            while os.getppid() == parent:
                time.sleep(1.0)
            os._exit(1)

        threading.Thread(target=watch, daemon=True).start()
    if os.getppid() != parent:
        os._exit(1)


def _init_worker(problem, progress_queue, parent):
    _die_with_parent(parent)
    _WORKER["problem"] = problem
    _WORKER["queue"] = progress_queue


def _worker(fn, *args):
    q = _WORKER["queue"]

    def report(*msg):
        q.put(msg)

    return fn(_WORKER["problem"], *args, report)


def run_in_processes(problem, fn: Callable, args: Sequence[tuple], n_proc: int, progress: Callable | None) -> list:
    """``fn(problem, *a, progress)`` for every ``a`` in ``args``, in ``n_proc`` forked processes when
    ``n_proc > 1``, else one after another in this process; ``fn`` must be a module-level function. Whatever
    ``fn`` passes to its progress callback reaches ``progress`` in this process. Returns the outputs in the
    order of ``args``."""
    if n_proc > 1 and "fork" in mp.get_all_start_methods():
        ctx = mp.get_context("fork")
        q = ctx.Queue()
        with ProcessPoolExecutor(
            n_proc, mp_context=ctx, initializer=_init_worker, initargs=(problem, q, os.getpid())
        ) as ex:
            futs = [ex.submit(_worker, fn, *a) for a in args]
            while not all(f.done() for f in futs):
                try:
                    msg = q.get(timeout=0.2)
                except _queue.Empty:
                    continue
                if progress is not None:
                    progress(*msg)
            results = [f.result() for f in futs]
            while progress is not None and not q.empty():
                progress(*q.get())
        return results
    return [fn(problem, *a, progress) for a in args]
