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
"""

from numba import njit

__all__ = ["FASTMATH", "kernel"]

FASTMATH = False

#: Decorator for the allocation-free kernels of the Newton loop.
kernel = njit(cache=True, fastmath=FASTMATH, _nrt=False)
