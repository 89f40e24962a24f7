"""The numba settings of the package's compiled kernels, and what they share.

Kernels are compiled on first use and cached beside the source (``cache=True``);
``nogil`` lets threads run them side by side.  :func:`on_first_compile` tells a
caller (the command line) when numba compiles instead of loading its cache.

A constant argument (``0``, ``True``) reaches a compiled callee as a literal type,
and numba compiles the callee once more, specialised to that value, beside its
compile for the variable's type (a quarter of a second for the law's mode functions
under ``_mode_of``).  Where a callee is also called with a variable, a kernel passes
the constant as ``np.int64(0)`` or ``np.bool_(True)``, whose types are not literal.
"""

import contextlib

import numba
from numba.core import event

__all__ = ["jit", "jit_unchecked", "inline", "borrowing", "borrowing_unchecked", "copy_into", "on_first_compile"]

#: Decorator of every compiled kernel of the shared switching and simulation modules.
jit = numba.njit(cache=True, nogil=True)
#: The same with numpy's error model: a float division by zero gives inf or NaN instead of raising.
#: For call-free helpers whose divisors cannot be zero: the raise path of a checked division
#: keeps numba from pruning the reference counts of their array arguments (the RK4 kernel's
#: stage helpers: reference counting 43 % of a run with it, 24 % without), for the
#: diagnosis' prediction kernels (``identify/_kernels.py``), whose divisors are positive,
#: and for the describing functions' kernels (``describing/_kernels.py``), whose inputs
#: ``describing._evaluation`` checks first.
jit_unchecked = numba.njit(cache=True, nogil=True, error_model="numpy")
#: The same for a small helper of a compiled loop, inlined into its callers by numba: a
#: compiled function that calls another makes numba reference-count its array arguments
#: on every call (NRT_incref/NRT_decref), a helper without calls does not.
inline = numba.njit(cache=True, nogil=True, inline="always")
#: :data:`jit` for a compiled loop that only borrows the arrays it is given (its caller holds
#: them) and allocates none, nor do the functions it calls (numba compiles them with its flags):
#: compiled without numba's reference counting, which otherwise counts an array passed to a
#: compiled call, or held by an inlined helper across one, at every call (a third of the RK4
#: kernel's event path, a quarter of the rubber law's describing function).  An allocation
#: below it fails to compile ("NRT required but not enabled"), never at run time.
borrowing = numba.njit(cache=True, nogil=True, _nrt=False)
#: :data:`borrowing` with numpy's error model (:data:`jit_unchecked`).
borrowing_unchecked = numba.njit(cache=True, nogil=True, error_model="numpy", _nrt=False)


@jit
def copy_into(src, dst):
    """``dst[...] = src`` for two arrays of one shape, element by element.

    An array-to-slice assignment makes numba compile its shape-mismatch message
    (string formatting), seconds on a cold cache; this loop does not.
    """
    for i in range(dst.size):
        dst.flat[i] = src.flat[i]


class _FirstCompile(event.Listener):
    """Calls ``announce()`` at the start of the first compilation numba reports, then never again."""

    def __init__(self, announce):
        self.announce = announce
        self.announced = False

    def on_start(self, data):
        if not self.announced:
            self.announced = True
            self.announce()

    def on_end(self, data):
        pass


@contextlib.contextmanager
def on_first_compile(announce):
    """Within the block, call ``announce()`` once when numba first compiles a function.

    numba reports ``numba:compile`` only when it compiles; a kernel loaded from its
    cache (a warm run) reports nothing, and ``announce`` is not called.
    """
    with event.install_listener("numba:compile", _FirstCompile(announce)):
        yield
