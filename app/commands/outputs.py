"""Where a command writes, checked before it computes anything: ``--json`` names a regular file (or
none yet) in a writable directory, and no output is, holds or lies in one of the command's inputs
(the ``--config`` file, a replayed log's directory), by real path, hard link or symbolic link. JSON
is written atomically (:func:`write_json_atomic`), so no half-written file is ever left.
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
import tempfile
from collections.abc import Callable, Sequence
from typing import IO, Any

from app.commands.values import UsageError
from app.reports.files import new_file_mode
from tauvcore.logs.writer import same_file
from tauvcore.validation import show, show_path

Inputs = Sequence[tuple[str, str | None]]
"""What a command reads (or writes elsewhere), as (description, path) pairs such as
``("the --config file", args.config)`` or ``("the log directory", args.log)``; a directory
stands for every file in it. An output may be none of them (:func:`json_target`)."""


def json_target(path: str, inputs: Inputs = ()) -> str:
    """The real path ``--json`` will replace, checked before the run starts.

    Refused: an empty name, one of ``inputs`` (:func:`_refuse_input`: the --config file, a
    replayed log's tables and its log.toml, by real path or inode), a directory, anything but a
    regular file (``/dev/null`` would be replaced by a file), a missing or unwritable directory,
    and a name the system cannot resolve (loops, too long).
    """
    return output_target("--json", path, inputs)


def output_target(flag: str, path: str, inputs: Inputs = (), exists: str | None = None) -> str:
    """The real path the file ``path`` given for ``flag`` will be written to, checked before the
    command computes anything: a name (not empty, no NUL character), none of ``inputs``
    (:func:`_refuse_input`), and :func:`writable_target`.

    Parameters
    ----------
    flag : str
        The flag that names the file, for the messages (``--json``, ``--out``).
    path : str
        The file's name as given.
    inputs : Inputs
        What the command reads, which the file may not be, hold or lie in.
    exists : str or None
        The end of the message that refuses an existing file ("exists; give --replace to replace
        it"); None: an existing regular file is replaced.

    Returns
    -------
    str
        The real path (symbolic links resolved).
    """
    if not path.strip():
        raise UsageError(f"{flag}: expected a file name, got {show(path)}")
    if "\x00" in path:
        raise UsageError(f"{flag}: a file name cannot contain a NUL character, got {show_path(path)}")
    _refuse_input(flag, path, inputs)
    return writable_target(flag, path, exists)


def writable_target(flag: str, path: str, exists: str | None = None) -> str:
    """The real path of ``path`` (given for ``flag``) if a file can be written there: not a
    directory nor a special file, in an existing writable directory, and an existing file only
    when ``exists`` is None (else refused with the message "<flag>: <path> <exists>"); otherwise
    one line naming the flag, the file and the reason (:class:`UsageError`)."""
    name = show_path(path)
    real = os.path.realpath(path)
    try:
        st = os.stat(real)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise UsageError(f"{flag}: cannot write {name}: {exc.strerror or exc}") from None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise UsageError(f"{flag}: cannot write {name}: is a directory")
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise UsageError(f"{flag}: cannot write {name}: not a regular file")
    if st is not None and exists is not None:
        raise UsageError(f"{flag}: {name} {exists}")
    directory = os.path.dirname(real)
    if not os.path.isdir(directory):
        raise UsageError(f"{flag}: cannot write {name}: no such directory")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise UsageError(f"{flag}: cannot write {name}: directory not writable")
    return real


def _real(path: str | None) -> str | None:
    """The real path of ``path``; None for none or a name no system call takes (a NUL, which
    the command refuses where it reads the file)."""
    if not path:
        return None
    try:
        return os.path.realpath(path)
    except (OSError, ValueError):
        return None


def _inside(path: str, directory: str) -> bool:
    """Whether the real path ``path`` is the real path ``directory`` or below it."""
    return os.path.commonpath([path, directory]) == directory


def _same_as_one_in(path: str, directory: str) -> str | None:
    """The file directly in ``directory`` that is the file ``path`` (a hard link, or a symlink of
    either to the other), if any."""
    if not os.path.lexists(path) or not os.path.isdir(directory):
        return None
    try:
        with os.scandir(directory) as entries:
            return next((e.path for e in entries if same_file(path, e.path)), None)
    except OSError:
        return None


def _refuse_input(flag: str, path: str, inputs: Inputs) -> None:
    """UsageError if writing the file ``path`` for ``flag`` would replace one of ``inputs``: the
    same real path (symlinks resolved) or the same file (a hard link), a path inside an input
    directory, or the same file as one in it."""
    real, name = os.path.realpath(path), show_path(path)
    for what, source in inputs:
        source_real = _real(source)
        if source is None or source_real is None:
            continue
        if real == source_real or same_file(source_real, real):
            raise UsageError(f"{flag}: {name} is {what}; writing it would overwrite it")
        if _inside(real, source_real):
            raise UsageError(
                f"{flag}: {name} is in {what} {show_path(source)}; writing it could overwrite its files"
            )
        twin = _same_as_one_in(real, source_real)
        if twin is not None:
            raise UsageError(
                f"{flag}: {name} is the same file as {show_path(os.path.join(source, os.path.basename(twin)))} "
                f"in {what} {show_path(source)}; writing it would overwrite it"
            )


def write_json_atomic(path: str, payload: Any) -> None:
    """Write ``payload`` as strict JSON to ``path``, atomically (:func:`write_text_atomic`)."""
    write_text_atomic(path, lambda fh: json.dump(payload, fh, allow_nan=False))


def write_text_atomic(path: str, write: Callable[[IO[str]], object]) -> None:
    """Write a text file with ``write(fh)``: into a temporary file in the same directory, flushed
    to disk, then renamed over ``path``. On any failure or interruption the temporary file is
    removed and ``path`` is untouched, so no half-written file is ever left."""
    directory = os.path.dirname(path) or "."
    fd, tmp = tempfile.mkstemp(prefix=".tauv-", suffix=".json.tmp", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, new_file_mode(path))
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
