"""Compiler settings shared by the numba kernels.

``FASTMATH`` allows fused multiply-add, reassociation and reciprocal approximations but keeps IEEE NaN/Inf
semantics ('nnan'/'ninf' are left out): the solver relies on NaN checks to flag failed parameter sets.

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

FASTMATH = {"contract", "arcp", "reassoc", "nsz", "afn"}

#: Decorator for the allocation-free kernels of the Newton loop.
kernel = njit(cache=True, fastmath=FASTMATH, _nrt=False)
