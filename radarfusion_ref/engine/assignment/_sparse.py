"""Sparse matrices for scipy's compiled solvers, in the one index type every release takes."""

from __future__ import annotations

import numpy as np
from scipy import sparse


def int32_indices(a, fmt: str = "csr"):
    """`a` (a scipy sparse array) as a new CSR (or CSC) array with 32-bit index arrays.

    scipy 1.11's LAPJVsp, graph routines and HiGHS wrapper accept no other index type
    (later releases convert): given 64-bit indices they raise, or, for
    ``connected_components`` of a ``coo_array``, return every label as -9999. The sizes
    here are far below 2**31 (``MEMORY_LIMIT``).
    """
    out = sparse.csc_array(a, copy=True) if fmt == "csc" else sparse.csr_array(a, copy=True)
    out.indices, out.indptr = out.indices.astype(np.int32), out.indptr.astype(np.int32)
    return out
