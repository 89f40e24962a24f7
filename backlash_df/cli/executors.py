"""Where a sweep's cells run (``--workers``, ``--dask``, ``--scheduler``) and where they are kept (``--checkpoint``).

``--workers N`` runs the cells on a local process pool of N processes, with
``--dask`` on a ``dask.distributed.LocalCluster`` of N single-threaded workers;
``--scheduler ADDRESS`` runs them on an existing Dask cluster.  The cells are
pure functions of (rig, values), so the result does not depend on the choice.  On
Dask, a cell whose worker dies is run again on another worker.

Finished cells are kept in a checkpoint (:class:`~backlash_df.checkpoint.Checkpoint`):
``--checkpoint PATH`` from the first cell; by default, once the run has lasted
:data:`CHECKPOINT_AFTER` seconds, beside the first output file (``map.json`` ->
``map.json.checkpoint``) or, without one, as ``backlash-df-COMMAND.checkpoint`` in the
working directory.  Ctrl-C, or a worker process pool that breaks, keeps the cells
done and prints one line saying how to resume (``--resume``), and so does a cell
that killed every Dask worker it ran on (``KilledWorker``); a run that completes
removes its checkpoint once its outputs are written.
"""

import concurrent.futures
import contextlib
import os
from pathlib import Path

import click

from ..checkpoint import Checkpoint
from .common import fail
from .outputs import check_output_path

__all__ = ["executor_for", "executor_options", "checkpoint_for", "checkpoint_options", "stopped_note",
           "CHECKPOINT_AFTER"]

#: Seconds a run lasts before its default checkpoint is written.
CHECKPOINT_AFTER = 60.0


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


def checkpoint_options(function):
    """Add ``--checkpoint PATH`` and ``--resume`` to a command."""
    function = click.option("--resume", is_flag=True,
                            help="Continue from the checkpoint of an interrupted run of the same command.")(function)
    return click.option("--checkpoint", "checkpoint_path", type=click.Path(dir_okay=False), default=None,
                        help="Keep every finished cell in this file [default: beside the first output file, "
                             "or in the working directory, once the run has lasted a minute].")(function)


def _default_checkpoint(outputs, command):
    """``FIRST_OUTPUT.checkpoint`` beside the first output file, else ``backlash-df-COMMAND.checkpoint``;
    None where that folder cannot be written."""
    files = [Path(path) for path in outputs.paths.values()
             if str(path) != "-" and (Path(path).is_file() or not Path(path).exists())]
    path = files[0].with_name(files[0].name + ".checkpoint") if files else Path(f"backlash-df-{command}.checkpoint")
    return path if os.access(path.resolve().parent, os.W_OK | os.X_OK) else None


def checkpoint_for(outputs, command, path=None, resume=False):
    """The :class:`~backlash_df.checkpoint.Checkpoint` of ``--checkpoint``/``--resume`` (module docs), or None.

    Parameters
    ----------
    outputs : Outputs
        The command's output files (the default checkpoint goes beside the first).
    command : str
        ``"map"``, ``"continue"``.
    path : str, optional
        ``--checkpoint``: written from the first cell.
    resume : bool
        ``--resume``: continue from the checkpoint (it must exist).

    Raises
    ------
    ValueError
        ``--checkpoint`` cannot be written; the checkpoint exists without
        ``--resume`` or is missing with it.
    """
    if path is not None:
        check_output_path(path, "--checkpoint")
        return Checkpoint(path, resume=resume)
    default = _default_checkpoint(outputs, command)
    if default is None:
        if resume:
            raise ValueError("--resume: no checkpoint (the folder of the outputs is not writable); name it with "
                             "--checkpoint")
        return None
    return Checkpoint(default, resume=resume, after=CHECKPOINT_AFTER)


@contextlib.contextmanager
def stopped_note(checkpoint, unit="cells", total=None):
    """Turn Ctrl-C and a lost worker into one line: what was kept, and how to resume.

    Parameters
    ----------
    checkpoint : Checkpoint or None
    unit : str
        What the checkpoint counts (``"cells"``, ``"steps"``).
    total : int, optional
        How many there are in all (``"5 of 24 cells"``).
    """
    try:
        yield
    except KeyboardInterrupt:
        fail(f"interrupted; {_kept(checkpoint, unit, total)}", 1)
    except _worker_losses() as error:
        fail(f"a worker process died ({error}); {_kept(checkpoint, unit, total)}", 1)


def _worker_losses():
    """The exceptions of a lost worker: a broken process pool, and Dask's cell that killed every worker it ran on."""
    try:
        from distributed import KilledWorker
    except ImportError:
        return (concurrent.futures.BrokenExecutor,)
    return (concurrent.futures.BrokenExecutor, KilledWorker)


def _kept(checkpoint, unit, total):
    if checkpoint is None or not checkpoint.kept:
        return f"no {unit} had finished"
    of = f" of {total}" if total is not None else ""
    return (f"{checkpoint.kept}{of} {unit} kept in {checkpoint.path}: run the same command with --resume to "
            "continue")
