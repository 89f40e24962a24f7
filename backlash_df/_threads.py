"""One BLAS thread for small matrices (private).

The package's matrices are small (a loop's states, a fit's parameters): BLAS threads
spinning on a busy machine cost several times the work itself, a 10 x 10 matrix
exponential 1 ms with two OpenBLAS threads against 20 us with one.
"""


def single_threaded_blas():
    """A context holding BLAS to one thread (threadpoolctl)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")
