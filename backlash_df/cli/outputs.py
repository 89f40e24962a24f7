"""The files a command writes: every path checked before anything is computed, all written or none.

:class:`Outputs` holds the paths of one command's options (``--json``, ``--report``,
``--plot``, ``--csv``, ``--out``); :meth:`Outputs.write` stages every file beside its target and
renames them into place only when all are written, restoring what it replaced if a
step fails.  A path's suffix names its format (:data:`SUFFIXES`): ``--plot`` writes the
figure format its suffix names (:func:`plot_format`), and ``--json``, ``--report`` and
``--csv`` refuse a suffix of another kind of file.
"""

import contextlib
import os
import re
import shutil
import stat
import sys
import tempfile
import uuid
from pathlib import Path

from ..render.html import FIGURE_FORMATS

__all__ = ["Outputs", "check_output_path", "check_suffix", "plot_format", "SUFFIXES"]

#: The suffixes (lower case) of each kind of file the commands read or write.
SUFFIXES = {"JSON": (".json",), "an HTML report": (".html", ".htm"), "a figure": tuple(FIGURE_FORMATS),
            "CSV": (".csv",), "a rig file": (".toml",)}
#: The kind each option writes.
_KINDS = {"--json": "JSON", "--report": "an HTML report", "--plot": "a figure", "--rig-out": "a rig file", "--csv": "CSV"}


def _suffix(path):
    """The suffix of ``path``, lower case (``""`` for none)."""
    return Path(str(path)).suffix.lower()


def _listed(suffixes):
    """``.png, .pdf or .svg``."""
    return " or ".join(filter(None, [", ".join(suffixes[:-1]), suffixes[-1]]))


def check_suffix(path, option):
    """Check that ``path``'s suffix fits what ``option`` writes, before anything is computed.

    ``--plot`` takes a figure suffix (:data:`~backlash_df.render.html.FIGURE_FORMATS`) or
    none (PNG, as on a stream: ``-``); ``--json``, ``--report`` and ``--csv`` take any suffix
    but that of another kind of file (:data:`SUFFIXES`: ``--json m.html``, ``--report
    r.json``, ``--csv r.json``); ``--rig-out`` takes ``.toml`` only (a rig file ``load_rig``
    reads), or a stream (``-``).  Another option is not checked here.

    Raises
    ------
    ValueError
        One line naming ``option``, ``path`` and the suffixes to use.
    """
    kind, suffix = _KINDS.get(option), _suffix(path)
    if kind == "a rig file" and suffix not in SUFFIXES[kind] and _descriptor(path) is None:
        raise ValueError(f"{option} {path}: {option} writes {kind}, which needs the suffix "
                         f"{_listed(SUFFIXES[kind])}")
    if kind is None or not suffix or suffix in SUFFIXES[kind]:
        return
    if kind == "a figure":
        raise ValueError(f"{option} {path}: unknown plot format '{suffix}' (use {_listed(SUFFIXES[kind])})")
    other = next((name for name, suffixes in SUFFIXES.items() if suffix in suffixes), None)
    if other is not None:
        raise ValueError(f"{option} {path}: {option} writes {kind}, not {other} (use {_listed(SUFFIXES[kind])})")


def plot_format(path):
    """The figure format a ``--plot`` path names by its suffix (:func:`check_suffix`): ``"png"``, ``"pdf"`` or
    ``"svg"``; ``"png"`` without a suffix.

    Examples
    --------
    >>> plot_format("map.PDF"), plot_format("-")
    ('pdf', 'png')
    """
    return FIGURE_FORMATS.get(_suffix(path), "png")


def check_output_path(path, option="output"):
    """Check that ``path`` can be written, before anything is computed.

    Parameters
    ----------
    path : str or Path
        The file to write.  A symbolic link is followed; ``-`` and ``/dev/stdout``
        are the standard output; an existing device or pipe is written as it is.
    option : str
        The option or argument that named the path, for the message.

    Raises
    ------
    ValueError
        One line naming ``option`` and ``path``: a directory, a missing or
        unwritable parent directory, or an existing file that cannot be written.
    """
    where = f"{option} {path}"
    if _descriptor(path) is not None:
        try:
            os.fstat(_descriptor(path))
        except OSError:
            raise ValueError(f"{where}: no such open file descriptor") from None
        if _read_only(_descriptor(path)):
            raise ValueError(f"{where}: open for reading only")
        return
    target, stream = _target(path)
    if target.is_dir():
        raise ValueError(f"{where}: is a directory, give a file name")
    if stream:
        if not os.access(target, os.W_OK):
            raise ValueError(f"{where}: cannot write to it (permission denied)")
        return
    parent = target.parent
    shown = parent if Path(path).is_symlink() else Path(path).parent  # a link: where it points
    if parent.exists() and not parent.is_dir():
        raise ValueError(f"{where}: {shown} is a file, not a directory")
    if not parent.is_dir():
        raise ValueError(f"{where}: directory {shown} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"{where}: directory {shown} is not writable")
    if target.exists() and not os.access(target, os.W_OK):
        raise ValueError(f"{where}: file exists and is not writable")


_STANDARD_STREAMS = {"/dev/stdin": 0, "/dev/stdout": 1, "/dev/stderr": 2}
_FD_PATH = re.compile(r"/(?:dev/fd|proc/self/fd)/(\d+)")


def _read_only(fd):
    """True if descriptor ``fd`` was opened for reading only (unknown without ``fcntl``: False)."""
    try:
        import fcntl
    except ImportError:  # not on POSIX
        return False
    return fcntl.fcntl(fd, fcntl.F_GETFL) & os.O_ACCMODE == os.O_RDONLY


def _descriptor(path):
    """The open file descriptor that ``-`` or ``/dev/stdout`` (standard output), ``/dev/fd/N`` or
    ``/proc/self/fd/N`` names, or None."""
    if str(path) == "-":
        return 1
    name = os.path.abspath(path)
    match = _FD_PATH.fullmatch(name)
    return int(match[1]) if match else _STANDARD_STREAMS.get(name)


def _target(path):
    """The file ``path`` names, and whether it is a stream.

    A symbolic link is followed to the file it names (written through, not
    replaced).  An existing device or pipe is a stream, kept as given and
    written in place.
    """
    path = Path(path)
    if path.exists() and not path.is_file() and not path.is_dir():
        return path, True
    return Path(os.path.realpath(path)), False


def _new_file_mode(target):
    """Mode of a file that ``open`` would create (umask applied) or that exists already."""
    if target.exists():
        return stat.S_IMODE(target.stat().st_mode)
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def _write_descriptor(fd, data):
    """Write to an open descriptor: stdout and stderr through Python's streams (in order
    with what the command printed), others directly."""
    stream = {1: sys.stdout, 2: sys.stderr}.get(fd)
    if stream is None:
        os.write(fd, data if isinstance(data, bytes) else data.encode("utf-8"))
    elif isinstance(data, bytes):
        stream.flush()
        stream.buffer.write(data)
        stream.buffer.flush()
    else:
        stream.write(data)
        stream.flush()


def _stage(target, data):
    """Write ``data`` to a temporary file beside ``target`` with the mode ``open`` would give
    ``target``; returns the temporary path (renamed into place by the caller)."""
    mode = "wb" if isinstance(data, bytes) else "w"
    encoding = None if isinstance(data, bytes) else "utf-8"
    file_mode = _new_file_mode(target)
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.")
    try:
        with os.fdopen(fd, mode, encoding=encoding) as handle:
            handle.write(data)
        os.chmod(tmp, file_mode)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return tmp


def _write_stream(path, data):
    """Write to a descriptor path (``-``, ``/dev/stdout``, ``/dev/fd/N``) or an existing device or pipe."""
    fd = _descriptor(path)
    if fd is not None:
        _write_descriptor(fd, data)
        return
    with open(path, "wb" if isinstance(data, bytes) else "w", encoding=None if isinstance(data, bytes) else "utf-8") \
            as handle:
        handle.write(data)


def _is_stream(path):
    return _descriptor(path) is not None or _target(path)[1]


class Outputs:
    """The output files of one command: checked first, then all written or none.

    Parameters
    ----------
    paths : dict of str to path or None
        Option name (``"--json"``) to path; ``None`` entries (option not given)
        are skipped.

    Raises
    ------
    ValueError
        A suffix the option does not write (:func:`check_suffix`), a path that
        cannot be written (:func:`check_output_path`), or one file named by two
        options.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> outputs = Outputs({"--json": folder / "a.json", "--report": None})
    >>> outputs.write({"--json": "{}"})
    >>> (folder / "a.json").read_text()
    '{}'
    """

    def __init__(self, paths):
        self.paths = {option: path for option, path in paths.items() if path is not None}
        seen = {}
        for option, path in self.paths.items():
            check_suffix(path, option)
            check_output_path(path, option)
            target, stream = _target(path)
            if target in seen and not stream and _descriptor(path) is None:
                raise ValueError(f"{option} {path}: same file as {seen[target]}")
            seen[target] = option

    def __contains__(self, option):
        return option in self.paths

    def write(self, texts):
        """Write ``texts[option]`` (str or bytes) to each option's path: all files or none.

        Every regular file is first written in full to a temporary file beside
        it; only then are they renamed into place.  If a step fails, the
        temporary files are removed, files this call created are removed and
        files it replaced get their old content back; then a ``ValueError``
        names the option and the path.  Streams (standard output, pipes) are
        written last, when every file is in place.  Build every text before
        calling: nothing is computed between two writes.
        """
        files = {option: path for option, path in self.paths.items() if not _is_stream(path)}
        staged = {}
        for option, path in files.items():
            try:
                staged[option] = _stage(_target(path)[0], texts[option])
            except OSError as error:
                self._discard(staged.values())
                raise ValueError(f"{option} {path}: cannot write ({error.strerror}); no output written") from None
        placed = []
        for option, path in files.items():
            target, tmp, backup = _target(path)[0], staged.pop(option), None
            try:
                backup = _backup(target)
                os.replace(tmp, target)
            except OSError as error:
                self._discard([tmp, *staged.values(), *([backup] if backup is not None else [])])
                _roll_back(placed)
                raise ValueError(f"{option} {path}: cannot write ({error.strerror}); no output written") from None
            placed.append((target, backup))
        self._discard(backup for _, backup in placed if backup is not None)
        for option, path in self.paths.items():
            if option not in files:
                _write_stream(path, texts[option])

    @staticmethod
    def _discard(paths):
        for path in list(paths):
            with contextlib.suppress(OSError):
                os.unlink(path)


def _backup(target):
    """A hard link (or copy) of an existing ``target`` beside it, to restore it; None if there is none."""
    if not target.exists():
        return None
    backup = target.with_name(f".{target.name}.{uuid.uuid4().hex[:12]}.old")
    try:
        os.link(target, backup)
    except OSError:
        shutil.copy2(target, backup)
    return backup


def _roll_back(placed):
    """Undo renames: restore replaced files from their backups, remove the files created."""
    for target, backup in reversed(placed):
        with contextlib.suppress(OSError):
            if backup is None:
                os.unlink(target)
            else:
                os.replace(backup, target)
