"""``--workers N``, ``--dask`` and ``--scheduler ADDRESS``: where a sweep's cells run.

``--workers N`` runs the cells on a local process pool of N processes, with
``--dask`` on a ``dask.distributed.LocalCluster`` of N single-threaded workers;
``--scheduler ADDRESS`` runs them on an existing Dask cluster.  The cells are
pure functions of (rig, values), so the result does not depend on the choice.
"""

import contextlib

import click

__all__ = ["executor_for", "executor_options"]


@contextlib.contextmanager
def executor_for(workers, dask=False, scheduler=None):
    """A ``concurrent.futures.Executor`` for ``--workers/--dask/--scheduler`` (``None``: serial).

    Parameters
    ----------
    workers : int
        Local processes (1: run in this process, unless ``dask``).
    dask : bool
        Use a ``dask.distributed.LocalCluster`` of ``workers`` single-threaded workers.
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``).
    """
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    if dask or scheduler:
        try:
            import distributed
        except ImportError:
            raise ValueError("--dask/--scheduler need dask.distributed: pip install 'backlash-df[dask]'") from None
        with contextlib.ExitStack() as stack:
            if scheduler:
                try:
                    client = stack.enter_context(distributed.Client(scheduler, timeout="10s"))
                except OSError as error:
                    raise ValueError(f"--scheduler {scheduler}: cannot connect ({error})") from None
            else:
                cluster = stack.enter_context(distributed.LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None))
                client = stack.enter_context(distributed.Client(cluster))
            yield client.get_executor()
        return
    if workers == 1:
        yield None
        return
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(workers) as pool:
        yield pool


def executor_options(function):
    """Add ``--workers``, ``--dask`` and ``--scheduler`` to a command."""
    function = click.option("--scheduler", default=None, metavar="ADDRESS",
                            help="Run on an existing Dask cluster (scheduler address).")(function)
    function = click.option("--dask", is_flag=True, help="With --workers: a dask.distributed LocalCluster.")(function)
    return click.option("--workers", type=int, default=1, show_default=True,
                        help="Processes running the cells (a local process pool).")(function)
