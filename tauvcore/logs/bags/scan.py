"""Reading the messages of a ROS 1 bag or an MCAP file chunk by chunk: each chunk read with an
ordinary file read, decompressed (rosbags' own decompressors and checks: ROS 1's bz2 and lz4,
MCAP's zstd and lz4 with its CRC), its records walked by a compiled loop (:func:`ros1_records`,
:func:`mcap_records`) into arrays of (topic, receive time, offset, length) of the messages of the
topics wanted, and the messages of one topic and one length gathered into a 2-D byte array whose
columns :meth:`~tauvcore.logs.bags.messages.RawDecoder.decode_block` reads at once. No Python object is
made per message, and no more than one chunk's bytes are held.

The messages come in the order rosbags' ``messages()`` gives them: a topic's by receive time, ties
in the order of the file (its chunks in the order of the bag's index, the records of a chunk in
the order written). A ROS 1 topic of several connections, a connection id past :data:`MAX_ID` and
every other storage (ROS 2's sqlite3, an MCAP file without chunk index, several bags at once) are
left to rosbags (:func:`read_chunked` says which, before it reads anything); a chunk that does not
walk (truncated, corrupt) is an error.

:class:`Ros1Reader` is rosbags' ROS 1 reader that reads a chunk's message index only when asked
for that connection's messages (the index of a 1 h bag at 200 Hz is 1.4 million Python tuples,
seconds to read and 150 MB to hold, and the chunks give the same messages).
"""

from __future__ import annotations

import os
import struct
from collections import defaultdict
from collections.abc import Callable, Collection, Generator, Iterator, Mapping
from typing import Any

import numba
import numpy as np
from rosbags.rosbag1 import Reader as _RosbagsReader1

from tauvcore.logs.bags.files import MAX_CHUNK_BYTES, BagCorruptError

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")

MAX_ID = 65_535
"""The largest connection (channel) id the walks look up by id; a bag with a larger one is left to
rosbags (MCAP's ids are 16 bits; a ROS 1 bag's count up from 0)."""
MSGDATA = 2
"""A ROS 1 record's ``op`` of a message."""
MCAP_MESSAGE = 0x05
"""An MCAP record's opcode of a message."""


@_jit
def _u32(data: np.ndarray, at: int | np.int64) -> np.int64:
    """The little-endian uint32 at byte ``at`` of ``data``."""
    return (
        np.int64(data[at])
        | (np.int64(data[at + 1]) << 8)
        | (np.int64(data[at + 2]) << 16)
        | (np.int64(data[at + 3]) << 24)
    )


@_jit
def _u64(data: np.ndarray, at: int | np.int64) -> np.int64:
    """The little-endian uint64 at byte ``at`` of ``data`` (as int64: below 2**63 in a sane file)."""
    return _u32(data, at) | (_u32(data, at + 4) << 32)


@_jit
def _named(data: np.ndarray, at: int | np.int64, a: int, b: int, c: int, d: int) -> bool:
    """Whether the four bytes at ``at`` of ``data`` are ``a b c d``."""
    return data[at] == a and data[at + 1] == b and data[at + 2] == c and data[at + 3] == d


@_jit
def ros1_records(
    chunk: np.ndarray,
    slot_of: np.ndarray,
    slot: np.ndarray,
    time_ns: np.ndarray,
    offset: np.ndarray,
    length: np.ndarray,
) -> int:
    """The messages of the wanted connections in a decompressed ROS 1 chunk, in the chunk's order.

    A record is ``header_len (u32), header, data_len (u32), data``; the header's fields are each
    ``len (u32), name=value``: ``op`` (1 byte; 2 a message), ``conn`` (u32) and ``time`` (u32 s,
    u32 ns).

    Parameters
    ----------
    chunk : numpy.ndarray
        The chunk's bytes (B,) uint8.
    slot_of : numpy.ndarray
        Each connection id's slot (int64, by id), -1 for one not wanted; an id past its end is not
        wanted.
    slot : numpy.ndarray
        Out: each message's slot (M,) int64.
    time_ns : numpy.ndarray
        Out: each message's receive time [ns] (M,) int64.
    offset : numpy.ndarray
        Out: each message's data's byte offset in ``chunk`` (M,) int64.
    length : numpy.ndarray
        Out: each message's data's length [bytes] (M,) int64.

    Returns
    -------
    int
        The number of messages written; -1 for records that do not walk (truncated, a field
        missing), -2 for more messages than the arrays hold.
    """
    n = 0
    pos = 0
    size = chunk.size
    while pos < size:
        if pos + 4 > size:
            return -1
        header_end = pos + 4 + _u32(chunk, pos)
        if header_end + 4 > size:
            return -1
        op = -1
        conn = -1
        stamp = -1
        p = pos + 4
        while p < header_end:
            if p + 4 > header_end:
                return -1
            start = p + 4
            end = start + _u32(chunk, p)
            if end > header_end:
                return -1
            eq = start
            while eq < end and chunk[eq] != 61:  # '='
                eq += 1
            if eq == end:
                return -1
            name = eq - start
            value = eq + 1
            if name == 2 and end - value == 1 and chunk[start] == 111 and chunk[start + 1] == 112:  # op
                op = np.int64(chunk[value])
            elif name == 4 and end - value == 4 and _named(chunk, start, 99, 111, 110, 110):  # conn
                conn = _u32(chunk, value)
            elif name == 4 and end - value == 8 and _named(chunk, start, 116, 105, 109, 101):  # time
                stamp = _u32(chunk, value) * 1_000_000_000 + _u32(chunk, value + 4)
            p = end
        data = header_end + 4
        data_end = data + _u32(chunk, header_end)
        if data_end > size:
            return -1
        if op == MSGDATA:
            if conn < 0 or stamp < 0:
                return -1
            if conn < slot_of.size and slot_of[conn] >= 0:
                if n == slot.size:
                    return -2
                slot[n] = slot_of[conn]
                time_ns[n] = stamp
                offset[n] = data
                length[n] = data_end - data
                n += 1
        pos = data_end
    return n


@_jit
def mcap_records(
    chunk: np.ndarray,
    slot_of: np.ndarray,
    slot: np.ndarray,
    time_ns: np.ndarray,
    offset: np.ndarray,
    length: np.ndarray,
) -> int:
    """The messages of the wanted channels in a decompressed MCAP chunk, in the chunk's order.

    A record is ``opcode (u8), length (u64), content``; a message's content is ``channel_id
    (u16), sequence (u32), log_time (u64), publish_time (u64), data``.

    Parameters
    ----------
    chunk : numpy.ndarray
        The chunk's records (B,) uint8.
    slot_of : numpy.ndarray
        Each channel id's slot (int64, by id), -1 for one not wanted; an id past its end is not
        wanted.
    slot : numpy.ndarray
        Out: each message's slot (M,) int64.
    time_ns : numpy.ndarray
        Out: each message's log time [ns] (M,) int64.
    offset : numpy.ndarray
        Out: each message's data's byte offset in ``chunk`` (M,) int64.
    length : numpy.ndarray
        Out: each message's data's length [bytes] (M,) int64.

    Returns
    -------
    int
        The number of messages written; -1 for records that do not walk (truncated), -2 for more
        messages than the arrays hold.
    """
    n = 0
    pos = 0
    size = chunk.size
    while pos < size:
        if pos + 9 > size:
            return -1
        record = _u64(chunk, pos + 1)
        start = pos + 9
        if record < 0 or record > size - start:
            return -1
        end = start + record
        if chunk[pos] == MCAP_MESSAGE:
            if record < 22:
                return -1
            channel = np.int64(chunk[start]) | (np.int64(chunk[start + 1]) << 8)
            if channel < slot_of.size and slot_of[channel] >= 0:
                if n == slot.size:
                    return -2
                slot[n] = slot_of[channel]
                time_ns[n] = _u64(chunk, start + 6)
                offset[n] = start + 22
                length[n] = end - start - 22
                n += 1
        pos = end
    return n


KINDS = {"<f8": 0, "<f4": 1, "<i8": 2, "<u8": 3, "<i4": 4, "<u4": 5, "<i2": 6, "<u2": 7, "<i1": 8, "<u1": 9}
"""The codes :func:`fixed_rows` reads a field's little-endian numpy type by."""


@_jit
def _integer(data: np.ndarray, at: int | np.int64, kind: int) -> np.int64:
    """The integer field of code ``kind`` (:data:`KINDS`, 2 to 9) at byte ``at`` of ``data``."""
    if kind == 2 or kind == 3:
        return _u64(data, at)
    if kind == 4:
        return np.int64(np.int32(np.uint32(_u32(data, at))))
    if kind == 5:
        return _u32(data, at)
    if kind == 6:
        return np.int64(np.int16(np.uint16(np.int64(data[at]) | (np.int64(data[at + 1]) << 8))))
    if kind == 7:
        return np.int64(data[at]) | (np.int64(data[at + 1]) << 8)
    if kind == 8:
        return np.int64(np.int8(data[at]))
    return np.int64(data[at])


@_jit
def fixed_rows(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    chunk: np.ndarray,
    offset: np.ndarray,
    length: np.ndarray,
    size: int,
    check_at: np.ndarray,
    check_value: np.ndarray,
    cdr: bool,
    column_at: np.ndarray,
    column_kind: np.ndarray,
    rows: np.ndarray,
    stamps: np.ndarray,
    at: int,
) -> int:
    """The numbers of messages of one layout, read from their bytes in a chunk into ``rows`` and
    ``stamps`` from row ``at`` on, up to the first message not of that layout.

    Parameters
    ----------
    chunk : numpy.ndarray
        The chunk's bytes (B,) uint8.
    offset : numpy.ndarray
        The messages' byte offsets in ``chunk`` (M,) int64.
    length : numpy.ndarray
        The messages' lengths [bytes] (M,) int64.
    size : int
        The layout's length [bytes].
    check_at : numpy.ndarray
        The byte offsets of the layout's length prefixes (uint32) (P,) int64.
    check_value : numpy.ndarray
        Their values (P,) int64.
    cdr : bool
        CDR: the encapsulation header's second byte must be 1 (little-endian).
    column_at : numpy.ndarray
        The byte offset of each wanted field (C,) int64, in the rows' order, then a header's
        ``stamp.sec`` and ``stamp.nanosec`` where ``stamps`` is not empty.
    column_kind : numpy.ndarray
        Their types' codes (:data:`KINDS`) (C,) int64.
    rows : numpy.ndarray
        Out: the rows (K, R) float64.
    stamps : numpy.ndarray
        Out: the stamps [ns] (K,) int64; empty for a type without a header.
    at : int
        The row of ``rows`` the first message goes to.

    Returns
    -------
    int
        How many messages, from the first, were read.
    """
    word = np.zeros(8, dtype=np.uint8)
    f8 = word.view(np.float64)
    f4 = word[:4].view(np.float32)
    ncols = rows.shape[1]
    for i in range(offset.size):
        start = offset[i]
        if length[i] != size or (cdr and chunk[start + 1] != 1):
            return i
        for j in range(check_at.size):
            if _u32(chunk, start + check_at[j]) != check_value[j]:
                return i
        for c in range(ncols):
            p = start + column_at[c]
            kind = column_kind[c]
            if kind == 0:
                word[:] = chunk[p : p + 8]
                rows[at + i, c] = f8[0]
            elif kind == 1:
                word[:4] = chunk[p : p + 4]
                rows[at + i, c] = np.float64(f4[0])
            elif kind == 3:
                rows[at + i, c] = np.float64(_u32(chunk, p + 4)) * 4294967296.0 + np.float64(_u32(chunk, p))
            else:
                rows[at + i, c] = np.float64(_integer(chunk, p, int(kind)))
        if stamps.size:
            sec = _integer(chunk, start + column_at[ncols], int(column_kind[ncols]))
            nanosec = _integer(chunk, start + column_at[ncols + 1], int(column_kind[ncols + 1]))
            stamps[at + i] = sec * 1_000_000_000 + nanosec
    return offset.size


class Ros1Reader(_RosbagsReader1):
    """rosbags' ROS 1 reader (``rosbags.rosbag1.Reader``) that skips the chunks' message indexes
    when it opens and reads those of a connection the first time its messages are asked for; a
    connection's ``msgcount`` is the bag's chunk infos' count of it (what the indexes hold).

    Parameters
    ----------
    path : pathlib.Path
        The bag.
    """

    def __init__(self, path: Any) -> None:
        super().__init__(path)
        self.index_records: list[tuple[int, int]] = []  # (chunk position, index record position)
        self.loaded: set[int] = set()  # the connections whose indexes are read

    def open(self) -> None:
        """Open the bag and read its connections and chunk infos (rosbags' ``open``)."""
        self.index_records = []
        self.loaded = set()
        super().open()
        counts: dict[int, int] = defaultdict(int)
        for info in self.chunk_infos:
            for conn, count in info.connection_counts.items():
                counts[conn] += count
        self.connections = [c._replace(msgcount=counts.get(c.id, 0)) for c in self.connections]

    def read_index_data(self, pos: int, indexes: dict[int, list[Any]]) -> None:
        """Note where the index record at the file's position is and step over it (its entries
        are read by :meth:`messages`).

        Parameters
        ----------
        pos : int
            The position of the chunk it indexes.
        indexes : dict
            rosbags' accumulated index, left as it is.
        """
        bio = self.bio
        assert bio is not None
        self.index_records.append((pos, bio.tell()))
        for _ in range(2):  # the header, then the entries: each a uint32 length and its bytes
            size = bio.read(4)
            if len(size) != 4:
                raise struct.error(f"the index after the chunk at byte {pos} is truncated")
            bio.seek(struct.unpack("<I", size)[0], os.SEEK_CUR)

    def messages(
        self, connections: Collection[Any] = (), start: int | None = None, stop: int | None = None
    ) -> Generator[tuple[Any, int, bytes], None, None]:
        """rosbags' ``messages``, the indexes of ``connections`` read first.

        Parameters
        ----------
        connections : Collection of rosbags.interfaces.Connection
            The connections whose messages are wanted; all where empty.
        start : int or None
            Only messages received at or after this time [ns].
        stop : int or None
            Only messages received before this time [ns].

        Returns
        -------
        Generator of tuple of Connection, int and bytes
            Each message's connection, receive time [ns] and bytes, by receive time.
        """
        wanted = {c.id for c in (connections or self.connections)} - self.loaded
        if wanted:
            self._load(wanted)
        return super().messages(connections, start, stop)

    def _load(self, wanted: set[int]) -> None:
        """Read the index records of the connections ``wanted`` (rosbags' ``read_index_data``)."""
        from rosbags.rosbag1.reader import Header, RecordType

        bio = self.bio
        assert bio is not None
        indexes: dict[int, list[Any]] = defaultdict(list)
        for pos, at in self.index_records:
            bio.seek(at)
            if Header.read(bio, RecordType.IDXDATA).get_uint32("conn") in wanted:
                bio.seek(at)
                super().read_index_data(pos, indexes)
        for conn in wanted:
            self.indexes[conn] = sorted(indexes[conn])
        self.loaded |= wanted


class NotScannedError(Exception):
    """A bag :func:`read_chunked` leaves to rosbags (module docstring)."""


def _ros1_chunks(storage: Any, conns: Collection[int]) -> Iterator[tuple[np.ndarray, int, int]]:
    """The decompressed chunks of a ROS 1 bag that hold any of connections ``conns``, in the
    order of its index, each with its first and last receive time (none outside: -1, 2**63)."""
    bio = storage.bio
    for info in storage.chunk_infos:
        if not any(info.connection_counts.get(c, 0) for c in conns):
            continue
        chunk = storage.chunks[info.pos]
        bio.seek(chunk.datapos)
        data = bio.read(chunk.datasize)
        if len(data) != chunk.datasize:
            raise struct.error(f"the chunk at byte {info.pos} is truncated")
        yield np.frombuffer(chunk.decompressor(data), dtype=np.uint8), -1, 2**63 - 1


def _mcap_chunks(storage: Any, conns: Collection[int]) -> Iterator[tuple[np.ndarray, int, int]]:
    """The decompressed chunks of an MCAP file that hold any of channels ``conns``, in the
    file's order (rosbags' ``decompress``: size and CRC checked), each with the log time range
    its messages are taken from (rosbags': the chunk's start to its end)."""
    from rosbags.rosbag2.storage_mcap import decompress

    bio = storage.bio
    for info in sorted(storage.chunks, key=lambda c: c.chunk_start_offset):
        if not any(info.channel_count.get(c, 0) for c in conns):
            continue
        if info.uncompressed_size > MAX_CHUNK_BYTES:
            raise BagCorruptError(
                f"the chunk at byte {info.chunk_start_offset} claims {info.uncompressed_size} bytes "
                f"uncompressed (at most {MAX_CHUNK_BYTES} are read)"
            )
        bio.seek(info.chunk_start_offset + 9 + 24)
        head = bio.read(4)
        bio.seek(info.chunk_start_offset + 9 + 40 + len(info.compression))
        data = bio.read(info.compressed_size)
        if len(head) != 4 or len(data) != info.compressed_size:
            raise struct.error(f"the chunk at byte {info.chunk_start_offset} is truncated")
        raw = decompress(data, info.compression, info.uncompressed_size, struct.unpack("<I", head)[0])
        yield np.frombuffer(raw, dtype=np.uint8), info.message_start_time, info.message_end_time


def read_chunked(
    reader: Any,
    connections: Collection[Any],
    take: Mapping[str, Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], None]],
) -> None:
    """Hand every message of ``connections`` to its topic's ``take``, chunk by chunk (module
    docstring): ``take[topic](chunk, received_ns, offset, length)`` with the chunk's bytes (B,)
    uint8 and the receive times [ns], data offsets and lengths [bytes] (M,) int64 of that topic's
    messages in it, in the topic's order.

    Parameters
    ----------
    reader : rosbags.highlevel.AnyReader
        The bag, open.
    connections : Collection of rosbags.interfaces.Connection
        The connections wanted.
    take : Mapping of str to Callable
        By topic, what takes its messages.

    Raises
    ------
    NotScannedError
        Before any message is handed on, for a bag this does not read (module docstring).
    struct.error, ValueError, OSError, or rosbags' and the decompressors' errors
        For a truncated or corrupt chunk (:func:`tauvcore.logs.bags.ros_reader.bag_errors`).
    """
    from rosbags.rosbag2.storage_mcap import McapReader

    if len(reader.readers) != 1:
        raise NotScannedError
    bag = reader.readers[0]
    topics = sorted({c.topic for c in connections})
    if isinstance(bag, Ros1Reader):
        if len({c.id for c in connections}) != len(connections) or len(connections) != len(topics):
            raise NotScannedError  # a topic of several connections: rosbags' merge orders their ties
        walk, chunks = ros1_records, _ros1_chunks(bag, [c.id for c in connections])
        minimum = 8  # bytes of the smallest record
    elif isinstance(getattr(bag, "storage", None), McapReader) and bag.storage.chunks:
        walk, chunks = mcap_records, _mcap_chunks(bag.storage, [c.id for c in connections])
        minimum = 31
    else:
        raise NotScannedError
    if not connections:
        return
    if max(c.id for c in connections) > MAX_ID:
        raise NotScannedError
    slot_of = np.full(max(c.id for c in connections) + 1, -1, dtype=np.int64)
    for c in connections:
        slot_of[c.id] = topics.index(c.topic)
    out = [np.empty(0, dtype=np.int64) for _ in range(4)]
    for chunk, first_ns, last_ns in chunks:
        if out[0].size < chunk.size // minimum + 1:
            out = [np.empty(chunk.size // minimum + 1, dtype=np.int64) for _ in range(4)]
        n = walk(chunk, slot_of, *out)
        if n < 0:
            raise ValueError("a chunk's records do not walk (truncated or corrupt)")
        slot, time_ns, offset, length = (a[:n] for a in out)
        inside = (time_ns >= first_ns) & (time_ns <= last_ns)
        for k, topic in enumerate(topics):
            mine = np.flatnonzero((slot == k) & inside)
            if mine.size:
                take[topic](chunk, time_ns[mine], offset[mine], length[mine])
