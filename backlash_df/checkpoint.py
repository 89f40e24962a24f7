"""Checkpoints of long runs: the finished cells of a map, a continuation or a tuning, kept on disk.

A run that is stopped (Ctrl-C, a killed process, a lost cluster) keeps the cells it
has finished in a checkpoint file; the same run resumed from it computes only the
others, and its result is identical to that of an uninterrupted run (every cell is a
pure function of the run's inputs and its own).

The file is JSON lines.  The first line names the run: the command and every input
the cells depend on (the rig's values, the laws, the settings, the package version),
so that a resume with other inputs is refused instead of mixing results.  Each
further line is one finished cell, ``{"key": [...], "value": "..."}``: its key (the
grid values of a map cell, readable) and its value (base64 of a pickle, the very
bytes an executor sends between processes, so that a resumed value is bit for bit
the value computed).  A line is appended and flushed as soon as its cell finishes;
a line cut short by a killed process is dropped (that cell is computed again).
Pickles run code when loaded: resume only from checkpoints your own runs wrote.

:func:`run_cells` runs cells on any :class:`concurrent.futures.Executor` and keeps
each one in a :class:`Checkpoint` as it finishes.
"""

import base64
import collections.abc
import concurrent.futures
import contextlib
import dataclasses
import hashlib
import itertools
import json
import os
import pickle
import threading
import time
from pathlib import Path

import numpy as np

from ._version import __version__

__all__ = ["Checkpoint"]

_MAGIC = "backlash-df checkpoint"


def describe(value, omit=()):
    """A JSON-ready description of a run's input: dataclasses by field, small arrays as lists.

    Arrays of more than 16 values are described by the SHA-256 of their bytes,
    objects of other types by that of their pickle; dataclass fields named in
    ``omit`` are left out (a rig's ``source``: the same values from another file
    are the same run).
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {field.name: describe(getattr(value, field.name), omit) for field in dataclasses.fields(value)
                if field.name not in omit}
    if isinstance(value, collections.abc.Mapping):  # a dict, a rig's Uncertainty
        return {str(key): describe(item, omit) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [describe(item, omit) for item in value]
    if isinstance(value, np.ndarray):
        if value.size <= 16:
            return describe(value.tolist())
        return {"array sha256": hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest()}
    if isinstance(value, (np.generic, bool, int, float, str)) or value is None:
        return value.item() if isinstance(value, np.generic) else value
    return {"pickle sha256": hashlib.sha256(pickle.dumps(value)).hexdigest()}


def _flat(tree, prefix=""):
    """Dotted path -> leaf of a nested dict (lists are leaves)."""
    if not isinstance(tree, dict):
        return {prefix: tree}
    found = {}
    for key, item in tree.items():
        found.update(_flat(item, f"{prefix}.{key}" if prefix else key))
    return found


def _differences(kept, wanted):
    """Dotted paths where two run descriptions differ, sorted."""
    kept, wanted = _flat(kept), _flat(wanted)
    return sorted(key for key in kept.keys() | wanted.keys() if kept.get(key, ()) != wanted.get(key, ()))


def _key(key):
    """A cell key as a hashable tuple of JSON values (lists read back from the file become tuples)."""
    if isinstance(key, (list, tuple)):
        return tuple(_key(item) for item in key)
    return key.item() if isinstance(key, np.generic) else key


def _line(record):
    return json.dumps(record, separators=(",", ":")) + "\n"


class Checkpoint:
    """A checkpoint file of one run (module docs): finished cells, kept as they finish.

    Pass it (or just a path) as ``checkpoint=`` to
    :func:`~backlash_df.sweeps.design_map` or
    :func:`~backlash_df.continuation.continue_limit_cycles`.

    Parameters
    ----------
    path : str or Path
        The file.
    resume : bool
        Continue from the cells ``path`` holds (it must exist and belong to the
        same run).  Without ``resume`` an existing ``path`` is refused, so that no
        earlier run's cells are lost or reused unasked.
    after : float
        Seconds: a new file is written only once the run has lasted this long, or
        when the run stops on an exception or Ctrl-C (which always writes the cells
        done); until then the finished cells are held in memory.  0: from the first cell.

    Raises
    ------
    ValueError
        ``path`` exists without ``resume``, or is missing with ``resume``; at
        :meth:`open`: ``path`` is not a checkpoint, or belongs to another run (one
        line naming the inputs that differ).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "absolute.checkpoint"
    >>> with Checkpoint(path).open("absolute values", {"sign": -1}) as kept:
    ...     run_cells(abs, [-1.0, -2.0], checkpoint=kept)
    [1.0, 2.0]
    >>> with Checkpoint(path, resume=True).open("absolute values", {"sign": -1}) as kept:
    ...     kept.kept, kept[-2.0]
    (2, 2.0)
    """

    def __init__(self, path, *, resume=False, after=0.0):
        self.path = Path(path)
        self.resume = bool(resume)
        self.after = float(after)
        if self.resume and not self.path.is_file():
            raise ValueError(f"checkpoint {self.path}: no such file to resume from (nothing was kept)")
        if not self.resume and self.path.exists():
            raise ValueError(f"checkpoint {self.path} exists (kept by an interrupted run): resume from it "
                             "(--resume; resume=True in Python) or remove it")
        self._cells = {}
        self._held = []
        self._file = None
        self._header = None
        self._on_disk = None  # cells in the file; None: no file of this run yet
        self._started = None

    def __repr__(self):
        where = f"{self.kept} in the file" if self.written else "none written"
        return f"<Checkpoint {self.path}: {len(self._cells)} cells, {where}>"

    @property
    def written(self):
        """True once the file holds this run's header."""
        return self._on_disk is not None

    @property
    def kept(self):
        """Number of finished cells the file holds."""
        return self._on_disk or 0

    def __len__(self):
        return len(self._cells)

    def __contains__(self, key):
        return _key(key) in self._cells

    def __getitem__(self, key):
        return self._cells[_key(key)]

    def open(self, command, run):
        """Bind to one run: read the cells kept for it (``resume``) or check that the file is new.

        Parameters
        ----------
        command : str
            What runs (``"map"``, ``"continue"``, ``"tune"``).
        run : dict
            Every input the cells depend on (:func:`describe` makes it JSON-ready).

        Returns
        -------
        Checkpoint
            ``self``, a context manager: leaving it on an exception writes the cells
            held in memory; leaving it in any case closes the file.
        """
        if self._header is not None:
            raise ValueError(f"checkpoint {self.path}: already open for a run")
        header = json.loads(_line({_MAGIC: 1, "command": command,
                                   "run": describe({**run, "backlash-df": __version__})}))
        if self.resume:
            self._read(header)
        self._header = header
        self._started = time.monotonic()
        return self

    def _read(self, header):
        """Load the cells ``self.path`` keeps for the run ``header``; cut a line a killed run left unfinished."""
        data = self.path.read_bytes()
        if not data:  # created by a run killed before it wrote anything
            return
        complete = data.split(b"\n")[:-1]  # the last piece: empty, or a line a killed run did not finish
        try:
            kept = json.loads(complete[0]) if complete else None
        except ValueError:
            kept = None
        if not isinstance(kept, dict) or kept.get(_MAGIC) != 1:
            raise ValueError(f"checkpoint {self.path}: not a backlash-df checkpoint")
        if (kept.get("command"), kept.get("run")) != (header["command"], header["run"]):
            names = (_differences(kept.get("run"), header["run"]) if kept.get("command") == header["command"]
                     else [f"the command ({kept.get('command')})"])
            raise ValueError(f"checkpoint {self.path} belongs to another run (it differs in {', '.join(names[:4])}"
                             f"{', ...' if len(names) > 4 else ''}): remove it, or name another checkpoint")
        good = len(complete[0]) + 1
        for raw in complete[1:]:
            try:
                record = json.loads(raw)
                self._cells[_key(record["key"])] = pickle.loads(base64.b64decode(record["value"]))
            except Exception:  # a cell that cannot be read back is computed again, and so are those after it
                break
            good += len(raw) + 1
        if good < len(data):
            with open(self.path, "r+b") as handle:
                handle.truncate(good)
        self._on_disk = len(self._cells)

    def add(self, key, value):
        """Keep a finished cell: write it (flushed), or hold it until the run has lasted ``after`` seconds."""
        key = _key(key)
        self._cells[key] = value
        self._held.append(_line({"key": list(key) if isinstance(key, tuple) else key,
                                 "value": base64.b64encode(pickle.dumps(value, protocol=4)).decode("ascii")}))
        if self.written or time.monotonic() - self._started >= self.after:
            self.write()

    def write(self):
        """Write the header (for a new file) and the cells held in memory, and flush."""
        try:
            if self._file is None:
                self._file = open(self.path, "a", encoding="ascii")
                if not self.written:
                    self._file.write(_line(self._header))
                    self._on_disk = 0
            self._file.writelines(self._held)
            self._file.flush()
        except OSError as error:
            raise ValueError(f"checkpoint {self.path}: cannot write ({error.strerror})") from None
        self._on_disk += len(self._held)
        self._held.clear()

    def remove(self):
        """Delete the file this run wrote or resumed from (its outputs are written: nothing is left to resume)."""
        self.close()
        if self.written:
            with contextlib.suppress(FileNotFoundError):
                self.path.unlink()
            self._on_disk = None

    def close(self):
        """Close the file (cells held in memory stay unwritten)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self):
        return self

    def __exit__(self, kind, error, traceback):
        try:
            if kind is not None and self._held:
                with contextlib.suppress(ValueError):  # the run's own exception is the one to report
                    self.write()
        finally:
            self.close()
        return False


def _as_checkpoint(checkpoint):
    """``None``, a :class:`Checkpoint`, or a path (a new :class:`Checkpoint` there)."""
    if checkpoint is None or isinstance(checkpoint, Checkpoint):
        return checkpoint
    if isinstance(checkpoint, (str, os.PathLike)):
        return Checkpoint(checkpoint)
    raise TypeError(f"checkpoint must be a path or a Checkpoint, got {type(checkpoint).__name__}")


def opened(checkpoint, command, run):
    """A context for one run: the checkpoint opened for it, or a do-nothing context for ``None``."""
    checkpoint = _as_checkpoint(checkpoint)
    return contextlib.nullcontext() if checkpoint is None else checkpoint.open(command, run)


def step_counter(progress, stage):
    """A ``step()`` that reports each call as ``progress(stage, count, None)``, in order, from any thread.

    For a stage whose length is not known ahead (a branch's steps, a search's fits);
    ``progress`` None makes it do nothing.
    """
    lock, count = threading.Lock(), itertools.count(1)

    def step():
        with lock:
            if progress is not None:
                progress(stage, next(count), None)

    return step


def run_cells(function, items, *, executor=None, checkpoint=None, keys=None, progress=None, stage="cells"):
    """``[function(item) for item in items]``, on ``executor`` if given (order kept), keeping each cell as it finishes.

    Parameters
    ----------
    function : callable
        A picklable function (module level, or a :func:`functools.partial` of one).
    items : sequence
    executor : concurrent.futures.Executor, optional
        ``None`` runs serially in this process.  A Dask client's
        ``get_executor()`` runs a cell whose worker dies again on another worker
        (the scheduler's rule, up to ``distributed.scheduler.allowed-failures``).
    checkpoint : Checkpoint, optional
        Opened for the run (:meth:`Checkpoint.open`): the cells it holds are not
        computed again, the others are added as they finish (in any order).
    keys : sequence, optional
        The key of each item in ``checkpoint`` (default: the item itself).
    progress : callable, optional
        ``progress(stage, done, total)``: called once with the cells already kept,
        then as each cell finishes (the package's one progress protocol).
    stage : str
        The stage's name passed to ``progress``.

    Returns
    -------
    list
        The values, in the order of ``items``.

    Notes
    -----
    On an exception or Ctrl-C the cells not yet started are cancelled; the
    cells finished are in ``checkpoint``.
    """
    items = list(items)
    keys = items if keys is None else list(keys)
    found = {i: checkpoint[keys[i]] for i in range(len(items)) if checkpoint is not None and keys[i] in checkpoint}
    todo = [i for i in range(len(items)) if i not in found]

    def finished(index, value):
        found[index] = value
        if checkpoint is not None:
            checkpoint.add(keys[index], value)
        if progress is not None:
            progress(stage, len(found), len(items))

    if progress is not None:
        progress(stage, len(found), len(items))

    if executor is None:
        for index in todo:
            finished(index, function(items[index]))
    else:
        futures = {executor.submit(function, items[index]): index for index in todo}
        try:
            for future in concurrent.futures.as_completed(futures):
                finished(futures[future], future.result())
        finally:
            for future in futures:
                future.cancel()
    return [found[i] for i in range(len(items))]

