"""Compiler settings shared by the numba kernels.

``FASTMATH`` is off: strict IEEE arithmetic. With LLVM's fast-math flags (fused multiply-add, reassociation,
reciprocal approximations) the machine code of a kernel depended on whether the kernels it calls were compiled in
the same process or loaded from numba's on-disk cache (cross-function inlining and reassociation then differ), so a
cold and a warm run of the same seed differed in the last bits; the sloppy least-squares problems amplify that into
different optima (T1 paper start: cost 1.2548 cold vs 0.3557 warm). Strict arithmetic gives bit-identical results
either way, at about 10 % of the speed (T1: ~97 -> ~107 us per simulation on an idle machine).

``kernel`` compiles the small, allocation-free kernels called in the Newton loop (stress, tangent, fibre update,
6x6 solve) without numba's reference-counting runtime (``_nrt=False``). They only read and write arrays owned by the
caller, so no reference counting is needed, and dropping it removes the atomic increments and decrements on every
array argument of every call: measured on T1, 157 -> 103 us per simulation (benchmarks/bench_forward.py). A kernel
compiled this way cannot allocate (``np.empty`` inside it fails to compile), which is the intended constraint.
``_nrt`` is a private numba option (numba 0.59-0.68); if a future numba drops it, remove it here: results do not
change, only the speed.

numba's on-disk cache keys a function on its own file only, while the kernels it calls are compiled into it: after
an edit of a law's module the solver would go on running the old law's machine code. :func:`drop_stale_cache` (run
on import) therefore drops the cache of every kernel of ``bayestissue.mechanics`` whenever any of its sources
changed (a SHA-256 of them, stamped in ``__pycache__``); the next run recompiles (about a minute).
"""

import hashlib
from pathlib import Path

from numba import njit

__all__ = ["FASTMATH", "drop_stale_cache", "kernel"]

_ROOT = Path(__file__).resolve().parent


def drop_stale_cache(root: Path = _ROOT) -> bool:
    """Delete numba's cached kernels under ``root`` if its sources changed since they were cached; True if it did.
    Read-only installs are left alone (numba then caches elsewhere or not at all)."""
    sources = sorted(root.rglob("*.py"))
    digest = hashlib.sha256(b"".join(p.relative_to(root).as_posix().encode() + p.read_bytes() for p in sources))
    stamp = root / "__pycache__" / "kernels.sha256"
    try:
        if stamp.read_text() == digest.hexdigest():
            return False
    except OSError:
        pass
    try:
        for cached in [*root.rglob("*.nbi"), *root.rglob("*.nbc")]:
            cached.unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:
        return False
    return True


drop_stale_cache()

FASTMATH = False

#: Decorator for the allocation-free kernels of the Newton loop.
kernel = njit(cache=True, fastmath=FASTMATH, _nrt=False)
