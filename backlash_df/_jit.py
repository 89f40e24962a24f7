"""The numba settings of the package's compiled kernels, and one helper they share.

Kernels are compiled on first use and cached beside the source (``cache=True``);
``nogil`` lets threads run them side by side.
"""

import numba

__all__ = ["jit", "inline", "copy_into"]

#: Decorator of every compiled kernel of :mod:`backlash_df.system` and :mod:`backlash_df.simulation`.
jit = numba.njit(cache=True, nogil=True)
#: The same for a small helper of a compiled loop, inlined into its callers by numba.
inline = numba.njit(cache=True, nogil=True, inline="always")


@jit
def copy_into(src, dst):
    """``dst[...] = src`` for two arrays of one shape, element by element.

    An array-to-slice assignment makes numba compile its shape-mismatch message
    (string formatting), seconds on a cold cache; this loop does not.
    """
    for i in range(dst.size):
        dst.flat[i] = src.flat[i]
