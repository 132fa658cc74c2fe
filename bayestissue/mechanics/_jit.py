"""Compiler settings shared by the numba kernels.

``FASTMATH`` allows fused multiply-add, reassociation and reciprocal approximations but keeps IEEE NaN/Inf
semantics ('nnan'/'ninf' are left out): the solver relies on NaN checks to flag failed parameter sets.
"""

FASTMATH = {"contract", "arcp", "reassoc", "nsz", "afn"}
