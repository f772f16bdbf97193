"""What a bag's path is, checked before anything is opened; the file object rosbags reads it
through; what reading a bad bag raises (:func:`bag_errors`), said for a person (:func:`why`); and
the bounded read of a mapping's ``.msg`` files (:func:`msg_text`).

A bag is a regular file (a ROS 1 ``.bag``, an ``.mcap``, a ROS 2 ``.db3``) or a ROS 2 bag
directory holding ``metadata.yaml``; :func:`check_bag` says in one line what anything else is
(missing, a dangling symbolic link or a loop, a FIFO, a device or a socket, a directory that is
neither a log nor a ROS 2 bag, an empty file, a file whose first bytes are not its format's, an
MCAP file without its closing magic, a ``metadata.yaml`` that is not what rosbags reads) using
``stat`` and a non-blocking open, so a FIFO never blocks and a device is never read.

:class:`BoundedPath` is the path handed to rosbags: each file it opens for reading is a
:class:`BoundedReader`, whose reads are bounded by the file's real size (``os.fstat``), never
by a length a record claims, so a corrupt length of 2**64 - 1 costs no memory and the read that
ran past the end is named: "truncated or corrupt at byte N" (:func:`short_read`).
"""

from __future__ import annotations

import errno
import io
import os
import stat
import threading
from pathlib import Path
from typing import Any

from tauvcore.validation import LogError, show, show_path

ROS1_MAGIC = b"#ROSBAG V2.0\n"
"""A ROS 1 bag's first bytes."""
MCAP_MAGIC = b"\x89MCAP0\r\n"
"""An MCAP file's first and last bytes."""
SQLITE_MAGIC = b"SQLite format 3\x00"
"""A ROS 2 sqlite3 storage file's first bytes."""
MAGICS = {".bag": ROS1_MAGIC, ".mcap": MCAP_MAGIC, ".db3": SQLITE_MAGIC}
KIND_NAMES = {ROS1_MAGIC: "a ROS 1 bag", MCAP_MAGIC: "an MCAP file", SQLITE_MAGIC: "a ROS 2 sqlite3 file"}
SUFFIXES = {ROS1_MAGIC: ".bag", MCAP_MAGIC: ".mcap", SQLITE_MAGIC: ".db3"}
MCAP_MIN_BYTES = 8 + 9 + 4 + 37
"""The smallest MCAP file: its magic, a header record (an empty profile) and its footer and magic."""
METADATA = "metadata.yaml"
MAX_METADATA_BYTES = 16 << 20
"""The largest ``metadata.yaml`` read [bytes] (a recorder writes a few kB)."""
MAX_LINE_BYTES = 4096
"""The longest line a bag file's reader may ask for (ROS 1's first line is 13 bytes)."""
MAX_CHUNK_BYTES = 1 << 30
"""The largest decompressed chunk read [bytes] (a recorder's chunks are about 1 MB): a chunk that
claims more is refused before it is decompressed."""


class BagCorruptError(Exception):
    """A bag's record that cannot be what it claims (a chunk larger than :data:`MAX_CHUNK_BYTES`)."""


def _kind_of_mode(mode: int) -> str:
    if stat.S_ISFIFO(mode):
        return "a FIFO (a named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def entry_problem(path: str) -> str | None:
    """Why ``path`` is not a regular file to read, in words; None for a regular file (or a link
    to one). A directory is "a directory"."""
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        if os.path.islink(path):
            if exc.errno == errno.ELOOP:
                return "is a symbolic link loop"
            try:
                return f"is a dangling symbolic link (to {show_path(os.readlink(path))})"
            except OSError:
                return "is a dangling symbolic link"
        if exc.errno == errno.ENOENT:
            return "does not exist"
        if exc.errno == errno.ELOOP:
            return "is a symbolic link loop"
        return f"cannot be opened: {exc.strerror or exc}"
    if stat.S_ISDIR(mode):
        return "is a directory"
    if not stat.S_ISREG(mode):
        target = f" (a link to {show_path(os.path.realpath(path))})" if os.path.islink(path) else ""
        return f"is {_kind_of_mode(mode)}{target}, not a bag file"
    return None


def _open_regular(path: str) -> tuple[int, int]:
    """A descriptor of ``path`` opened non-blocking, checked a regular file on the descriptor, and
    its size [bytes]; OSError otherwise."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        raise OSError(errno.EINVAL, f"is {_kind_of_mode(st.st_mode)}, not a bag file")
    return fd, st.st_size


def _head_tail(path: str, n: int) -> tuple[bytes, bytes, int]:
    """The first and last ``n`` bytes of the regular file ``path`` and its size."""
    fd, size = _open_regular(path)
    try:
        head = os.pread(fd, n, 0)
        tail = os.pread(fd, n, max(size - n, 0))
    finally:
        os.close(fd)
    return head, tail, size


def check_bag(path: str | os.PathLike) -> None:
    """Refuse, in one line naming it, anything at ``path`` that is not a bag to read (module
    docstring); nothing is opened but a regular file, non-blocking.

    Parameters
    ----------
    path : str or os.PathLike
        What should be a ROS 1 bag, an MCAP or sqlite3 file, or a ROS 2 bag directory.

    Raises
    ------
    LogError
        Naming the path and what it is.
    """
    bag = os.fspath(path)
    problem = entry_problem(bag)
    if problem == "is a directory":
        _check_directory(bag)
        return
    if problem is not None:
        raise LogError(f"{show_path(bag)}: {problem}")
    try:
        head, tail, size = _head_tail(bag, 16)
    except OSError as exc:
        raise LogError(f"{show_path(bag)}: {exc.strerror or exc}") from None
    check_magic(bag, head, tail, size)


def check_magic(bag: str, head: bytes, tail: bytes, size: int, want: bytes | None = None) -> None:
    """Refuse a bag file that is empty, whose first bytes are not those of the format its name
    (or ``want``, a magic of :data:`KIND_NAMES`) says (another format's: say which), or an MCAP
    file cut before its closing magic; ``head`` and ``tail`` are its first and last 16 bytes."""
    if size == 0:
        raise LogError(f"{show_path(bag)}: is empty (0 bytes)")
    suffix = os.path.splitext(bag)[1].lower()
    found = next((m for m in KIND_NAMES if head.startswith(m)), None)
    want = want or MAGICS.get(suffix) or found or ROS1_MAGIC
    if found != want:
        if found is not None:
            raise LogError(
                f"{show_path(bag)}: {KIND_NAMES[found]} named {suffix or 'without a suffix'} (it would be "
                f"read as {KIND_NAMES[want]}; rename it {SUFFIXES[found]})"
            )
        if want.startswith(head):
            raise LogError(
                f"{show_path(bag)}: truncated: {size} bytes, fewer than {KIND_NAMES[want]}'s first line"
            )
        raise LogError(f"{show_path(bag)}: not {KIND_NAMES[want]} (it starts with {show(head)})")
    if want == MCAP_MAGIC and (size < MCAP_MIN_BYTES or not tail.endswith(MCAP_MAGIC)):
        raise LogError(
            f"{show_path(bag)}: truncated or corrupt: an MCAP file ends with a footer and its magic bytes, "
            f"this one ends at byte {size} without them"
        )


def _check_directory(bag: str) -> None:
    """A ROS 2 bag directory: its ``metadata.yaml`` a regular file of the layout rosbags reads, and
    each storage file it lists a regular file."""
    meta = os.path.join(bag, METADATA)
    if not os.path.lexists(meta):
        raise LogError(
            f"{show_path(bag)}: is a directory that is neither a log (no imu.csv or imu.parquet) nor a ROS 2 "
            f"bag (no {METADATA})"
        )
    problem = entry_problem(meta)
    if problem is not None:
        raise LogError(f"{show_path(meta)}: {problem}")
    try:
        fd, size = _open_regular(meta)
        try:
            data = os.read(fd, MAX_METADATA_BYTES + 1)
        finally:
            os.close(fd)
    except OSError as exc:
        raise LogError(f"{show_path(meta)}: cannot be read: {exc.strerror or exc}") from None
    if len(data) > MAX_METADATA_BYTES:
        raise LogError(f"{show_path(meta)}: larger than {MAX_METADATA_BYTES} bytes ({size} bytes)")
    info = _metadata(meta, data)
    storage = info["storage_identifier"]
    for name in info["relative_file_paths"]:
        part = os.path.join(bag, os.path.basename(name))
        problem = entry_problem(part)
        if problem is not None:
            raise LogError(f"{show_path(part)} (listed in {METADATA}): {problem}")
        if info.get("compression_mode", "") in ("", "none", "NONE", None):
            try:
                head, tail, size = _head_tail(part, 16)
            except OSError as exc:
                raise LogError(f"{show_path(part)}: {exc.strerror or exc}") from None
            want = {"mcap": MCAP_MAGIC, "sqlite3": SQLITE_MAGIC}.get(storage)
            if want is not None:
                check_magic(part, head, tail, size, want)


_METADATA_KEYS: dict[str, Any] = {
    "version": int,
    "storage_identifier": str,
    "relative_file_paths": list,
    "duration": dict,
    "starting_time": dict,
    "message_count": int,
    "topics_with_message_count": list,
}


def _metadata(meta: str, data: bytes) -> dict[str, Any]:
    """``metadata.yaml``'s ``rosbag2_bagfile_information``, checked key by key as rosbags reads it."""
    from ruamel.yaml import YAML

    def bad(what: str) -> LogError:
        return LogError(f"{show_path(meta)}: malformed: {what}")

    try:
        doc = YAML(typ="safe").load(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise bad(f"not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})") from None
    except Exception as exc:  # noqa: BLE001  (ruamel's parser and scanner errors, RecursionError)
        raise bad(f"not YAML: {' '.join(str(exc).split())[:200]}") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("rosbag2_bagfile_information"), dict):
        raise bad(f"no rosbag2_bagfile_information table (got {show(doc)})")
    info = doc["rosbag2_bagfile_information"]
    for key, kind in _METADATA_KEYS.items():
        value = info.get(key)
        if not isinstance(value, kind) or isinstance(value, bool):
            raise bad(f"rosbag2_bagfile_information.{key}: {kind.__name__} needed, got {show(value)}")
    if not all(isinstance(p, str) and p for p in info["relative_file_paths"]):
        raise bad(f"relative_file_paths: file names needed, got {show(info['relative_file_paths'])}")
    for key, sub in (("duration", "nanoseconds"), ("starting_time", "nanoseconds_since_epoch")):
        if not isinstance(info[key].get(sub), int) or isinstance(info[key].get(sub), bool):
            raise bad(f"{key}.{sub}: an integer needed, got {show(info[key].get(sub))}")
    for i, topic in enumerate(info["topics_with_message_count"]):
        meta_t = topic.get("topic_metadata") if isinstance(topic, dict) else None
        count = topic.get("message_count") if isinstance(topic, dict) else None
        if (
            not isinstance(meta_t, dict)
            or not all(isinstance(meta_t.get(k), str) for k in ("name", "type", "serialization_format"))
            or not isinstance(count, int)
        ):
            raise bad(
                f"topics_with_message_count[{i}]: topic_metadata (name, type, serialization_format) and "
                f"message_count needed, got {show(topic)}"
            )
    return info


# ------------------------------------------------------------------------------ bounded reading
_SHORT = threading.local()
"""This thread's first read that asked for more than its file held (:func:`short_read`)."""


def reset_short_read() -> None:
    """Forget the last short read (before a bag is opened)."""
    _SHORT.read = None


def short_read() -> str | None:
    """The first read since :func:`reset_short_read` that asked for more bytes than remained in
    its file, in words ("truncated or corrupt at byte N: ..."), or None."""
    return getattr(_SHORT, "read", None)


class BoundedReader(io.BufferedReader):
    """A regular file opened non-blocking for reading, whose ``read(n)`` and ``readline`` never ask
    for more than the file holds after the position (its size from ``os.fstat``): the same bytes as
    a plain file's, without the buffer of ``n`` bytes a corrupt record length would allocate.

    Parameters
    ----------
    path : str
        The file.
    """

    def __init__(self, path: str) -> None:
        fd, size = _open_regular(path)
        super().__init__(io.FileIO(fd, "rb", closefd=True))
        self.size = size

    def _bounded(self, size: int | None) -> int | None:
        if size is None or size < 0:
            return size
        at = self.tell()
        left = max(self.size - at, 0)
        if size > left:
            if short_read() is None:
                _SHORT.read = (
                    f"truncated or corrupt at byte {at}: a record claims {size} bytes there, the file "
                    f"holds {left} more"
                )
            return left
        return size

    def read(self, size: int | None = -1, /) -> bytes:
        return super().read(self._bounded(size))

    def read1(self, size: int = -1, /) -> bytes:
        bounded = self._bounded(size)
        return super().read1(-1 if bounded is None else bounded)

    def readline(self, size: int | None = -1, /) -> bytes:
        limit = MAX_LINE_BYTES if size is None or size < 0 else min(size, MAX_LINE_BYTES)
        return super().readline(limit)


class BoundedPath(type(Path())):  # type: ignore[misc]  # pathlib's concrete class of this system
    """The path rosbags is given: a file it opens for binary reading is a :class:`BoundedReader`
    (a child path, ``bag / "x.mcap"``, is one too)."""

    def open(self, mode: str = "r", buffering: int = -1, encoding: str | None = None,
             errors: str | None = None, newline: str | None = None) -> Any:  # fmt: skip
        if mode == "rb":
            return BoundedReader(os.fspath(self))
        return super().open(mode, buffering, encoding, errors, newline)


# ------------------------------------------------------------------------------------- errors
def bag_errors() -> tuple[type[BaseException], ...]:
    """What reading a bad bag or definition raises: rosbags' own errors, and what its storage
    layers raise on a truncated or corrupt file (sqlite3, struct, the decompressors, bad text)."""
    import sqlite3
    import struct

    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as ReaderError1
    from rosbags.rosbag2 import ReaderError as ReaderError2
    from rosbags.serde import SerdeError
    from rosbags.typesys import TypesysError

    return (
        AnyReaderError,
        ReaderError1,
        ReaderError2,
        SerdeError,
        TypesysError,
        sqlite3.Error,
        struct.error,
        OSError,
        ValueError,  # UnicodeDecodeError among them
        KeyError,
        IndexError,
        RuntimeError,  # lz4's
        EOFError,
        AssertionError,  # rosbags asserts on a file's layout
        TypeError,  # ord() of the empty bytes at a file's end, and the like
        OverflowError,  # a length beyond what a buffer can hold
        MemoryError,  # a decompression bomb, or a length within bounds but beyond the memory
        RecursionError,
        BagCorruptError,
        *_yaml_errors(),
    )


def _yaml_errors() -> tuple[type[BaseException], ...]:
    """ruamel's errors (rosbags reads ``metadata.yaml`` with it) and zstandard's."""
    from ruamel.yaml.error import YAMLError, YAMLStreamError
    from zstandard import ZstdError

    return (YAMLError, YAMLStreamError, ZstdError)


def why(exc: BaseException) -> str:
    """What is wrong with a bag that raised ``exc`` while read, for a person: the read that ran
    past the end of its file where there was one (tauvcore.logs.bags.files.short_read), else the error."""
    short = short_read()
    if short is not None:
        return short
    if isinstance(exc, MemoryError):
        return "it asks for more memory than there is (a corrupt length or a decompression bomb)"
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


MAX_MSG_BYTES = 1 << 20
"""The largest ``.msg`` definition read [bytes] (a DVL's is a few kB)."""


def msg_text(path: Path, where: str) -> str:
    """A ``.msg`` file's text: a regular UTF-8 file of at most :data:`MAX_MSG_BYTES` (never a FIFO
    opened), else one LogError naming it."""
    name = os.fspath(path)
    problem = entry_problem(name)
    if problem is not None:
        raise LogError(f"{where}msg_paths: {show_path(name)}: {problem.replace(', not a bag file', '')}")
    try:
        with BoundedReader(name) as fh:
            data = fh.read(MAX_MSG_BYTES + 1)
    except OSError as exc:
        raise LogError(
            f"{where}msg_paths: {show_path(name)}: cannot be read: {exc.strerror or exc}"
        ) from None
    if len(data) > MAX_MSG_BYTES:
        raise LogError(f"{where}msg_paths: {show_path(name)}: larger than {MAX_MSG_BYTES} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise LogError(
            f"{where}msg_paths: {show_path(name)}: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})"
        ) from None
