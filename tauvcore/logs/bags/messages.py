"""The numbers each supported message holds: one flat row of floats per message, laid out per type
(:data:`LAYOUTS`), as the bag's own frames and units have them (tauvcore.logs.bags.ros_reader converts).

A DVL message with per-beam data gives its body velocity and validity, four beam velocities and
validities, four beam directions, four beam ids and whether it is water-track (NaN where the
message has none):

- ``marine_acoustic_msgs/Dvl``: ``beam_velocity`` along ``beam_unit_vec``, valid where
  ``beam_velocities_valid``; the body velocity valid with at least 3 ``num_good_beams``;
  water-track where ``velocity_mode`` is ``DVL_MODE_WATER`` (2), else bottom-track;
- ``ds_sensor_msgs/Dvl``: ``raw_velocity`` along ``beam_unit_vec`` when ``coordinate_mode`` is
  beam coordinates (0), else no beams, each valid unless NaN (the driver's beam without a return); the body velocity and the mode as marine_acoustic_msgs';
- ``cola2_msgs/DVL`` and ``uuv_sensor_ros_plugins_msgs/DVL``: four ``beams`` (else none), each
  valid where its ``range`` is not negative, its direction the x axis of its ``pose``; the body
  velocity invalid where ``velocity_covariance[0]`` is negative (their -1);
- ``waterlinked_a50_ros_driver/DVL``: four ``beams`` with their ``id`` and ``valid`` (no
  directions: the mapping's ``beam_ids`` says which is which); ``velocity_valid``.

The last three say nothing of the mode (the bag mapping's ``water_track`` may).

The other types' rows are plain numeric fields (:data:`FIELDS`), which :class:`RawDecoder` reads
straight from many messages' serialised bytes at once (a topic of a 200 Hz IMU or reference holds
hundreds of thousands), without building a Python object per message: the fields' byte offsets are
found once per layout (the values of the length prefixes of the strings and sequences before
them) by walking the type's definition, checked against rosbags' own deserialisation of that
message, and read for every message of that layout as one numpy column.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from tauvcore.aiding.source import BagMessage
from tauvcore.logs.bags.scan import KINDS, fixed_rows
from tauvcore.validation import LogError

NAN = float("nan")
_NO_BEAMS = (NAN,) * 4 + (0.0,) * 4 + (NAN,) * 12 + (NAN,) * 4
DVL_MODE_WATER = 2
"""``velocity_mode`` of a water-track ping (marine_acoustic_msgs' and ds_sensor_msgs' ``DVL_MODE_WATER``)."""


def _water(m: Any) -> float:
    return 1.0 if m.velocity_mode == DVL_MODE_WATER else 0.0


def _vec(v: Any) -> tuple[float, float, float]:
    return (v.x, v.y, v.z)


def _quat(q: Any) -> tuple[float, float, float, float]:
    return (q.x, q.y, q.z, q.w)


def _beam_axis(q: Any) -> tuple[float, float, float]:
    """The x axis of the rotation of quaternion ``q``: a UUV Simulator beam's direction."""
    x, y, z, w = _quat(q)
    n = x * x + y * y + z * z + w * w
    return (1.0 - 2.0 * (y * y + z * z) / n, 2.0 * (x * y + w * z) / n, 2.0 * (x * z - w * y) / n)


def _marine_acoustic(m: Any) -> tuple[float, ...]:
    valid = 1.0 if m.beam_velocities_valid else 0.0
    dirs = [c for v in m.beam_unit_vec for c in _vec(v)]
    return (
        *_vec(m.velocity),
        1.0 if m.num_good_beams >= 3 else 0.0,
        *(float(v) for v in m.beam_velocity),
        *(valid,) * 4,
        *dirs,
        *(NAN,) * 4,
        _water(m),
    )


def _ds(m: Any) -> tuple[float, ...]:
    body = (*_vec(m.velocity), 1.0 if m.num_good_beams >= 3 else 0.0)
    if m.coordinate_mode != 0:  # x, y, z, error: no beams
        return body + _NO_BEAMS + (_water(m),)
    dirs = [c for v in m.beam_unit_vec for c in _vec(v)]
    raw = [float(v) for v in m.raw_velocity]
    valid = (0.0 if math.isnan(v) else 1.0 for v in raw)  # the driver's NaN: the beam did not return
    return body + (*raw, *valid, *dirs, *(NAN,) * 4, _water(m))


def _uuv(m: Any) -> tuple[float, ...]:
    body = (*_vec(m.velocity), 0.0 if m.velocity_covariance[0] < 0 else 1.0)
    beams = m.beams
    if len(beams) != 4:
        return body + _NO_BEAMS + (NAN,)
    return body + (
        *(b.velocity for b in beams),
        *(1.0 if b.range >= 0 else 0.0 for b in beams),
        *(c for b in beams for c in _beam_axis(b.pose.pose.orientation)),
        *(NAN,) * 4,
        NAN,
    )


def _waterlinked(m: Any) -> tuple[float, ...]:
    body = (*_vec(m.velocity), 1.0 if m.velocity_valid else 0.0)
    beams = m.beams
    if len(beams) != 4:
        return body + _NO_BEAMS + (NAN,)
    return body + (
        *(b.velocity for b in beams),
        *(1.0 if b.valid else 0.0 for b in beams),
        *(NAN,) * 12,
        *(float(b.id) for b in beams),
        NAN,
    )


_DVL = {"body": slice(0, 3), "body_valid": slice(3, 4), "beams": slice(4, 8), "beam_valid": slice(8, 12),
        "dirs": slice(12, 24), "ids": slice(24, 28), "water": slice(28, 29)}  # fmt: skip
_POSE = {"position": slice(0, 3), "quaternion": slice(3, 7)}


def _xyz(name: str) -> tuple[str, ...]:
    return tuple(f"{name}.{a}" for a in "xyz")


def _xyzw(name: str) -> tuple[str, ...]:
    return tuple(f"{name}.{a}" for a in "xyzw")


FIELDS: dict[str, tuple[str, ...]] = {
    "sensor_msgs/msg/Imu": (
        *_xyz("angular_velocity"),
        *_xyz("linear_acceleration"),
        *_xyzw("orientation"),
    ),
    "geometry_msgs/msg/QuaternionStamped": _xyzw("quaternion"),
    "geometry_msgs/msg/Vector3Stamped": _xyz("vector"),
    "geometry_msgs/msg/PoseStamped": (*_xyz("pose.position"), *_xyzw("pose.orientation")),
    "geometry_msgs/msg/PoseWithCovarianceStamped": (
        *_xyz("pose.pose.position"),
        *_xyzw("pose.pose.orientation"),
    ),
    "nav_msgs/msg/Odometry": (
        *_xyz("pose.pose.position"),
        *_xyzw("pose.pose.orientation"),
        *_xyz("twist.twist.linear"),
    ),
    "sensor_msgs/msg/NavSatFix": ("latitude", "longitude", "altitude"),
    "sensor_msgs/msg/FluidPressure": ("fluid_pressure",),
    "std_msgs/msg/Float64": ("data",),
    "std_msgs/msg/Float32": ("data",),
}
"""The types whose row is numeric fields, as dotted paths in the message, in the row's order
(read per message by :data:`EXTRACT`, or many at once from their bytes by :class:`RawDecoder`)."""
IMU_RATES = FIELDS["sensor_msgs/msg/Imu"][:6]
"""An IMU's rates alone: the fields of a topic that feeds the ``imu`` table and nothing else (its
orientation is not read)."""


def _fields(paths: tuple[str, ...]) -> Callable[[Any], tuple[float, ...]]:
    """A message's fields ``paths`` as floats (attrgetter: one Python call for them all)."""
    get: Any = operator.attrgetter(*paths)
    if len(paths) == 1:
        return lambda m: (float(get(m)),)
    return lambda m: tuple(map(float, get(m)))


EXTRACT: dict[str, Callable[[Any], tuple[float, ...]]] = {
    **{kind: _fields(paths) for kind, paths in FIELDS.items()},
    "geometry_msgs/msg/TwistStamped": lambda m: (*_vec(m.twist.linear), 1.0),
    "geometry_msgs/msg/TwistWithCovarianceStamped": lambda m: (*_vec(m.twist.twist.linear), 1.0),
    "marine_acoustic_msgs/msg/Dvl": _marine_acoustic,
    "ds_sensor_msgs/msg/Dvl": _ds,
    "cola2_msgs/msg/DVL": _uuv,
    "uuv_sensor_ros_plugins_msgs/msg/DVL": _uuv,
    "waterlinked_a50_ros_driver/msg/DVL": _waterlinked,
}
"""Each supported type's row of numbers (:data:`LAYOUTS` names its parts)."""
LAYOUTS: dict[str, dict[str, slice]] = {
    "sensor_msgs/msg/Imu": {"gyro": slice(0, 3), "accel": slice(3, 6), "quaternion": slice(6, 10)},
    "geometry_msgs/msg/QuaternionStamped": {"quaternion": slice(0, 4)},
    "geometry_msgs/msg/Vector3Stamped": {"vector": slice(0, 3)},
    "geometry_msgs/msg/PoseStamped": _POSE,
    "geometry_msgs/msg/PoseWithCovarianceStamped": _POSE,
    "nav_msgs/msg/Odometry": {**_POSE, "velocity_b": slice(7, 10)},
    "sensor_msgs/msg/NavSatFix": {"lat_lon_deg": slice(0, 2), "altitude": slice(2, 3)},
    "sensor_msgs/msg/FluidPressure": {"pressure": slice(0, 1)},
    "std_msgs/msg/Float64": {"value": slice(0, 1)},
    "std_msgs/msg/Float32": {"value": slice(0, 1)},
    "geometry_msgs/msg/TwistStamped": {"body": slice(0, 3), "body_valid": slice(3, 4)},
    "geometry_msgs/msg/TwistWithCovarianceStamped": {"body": slice(0, 3), "body_valid": slice(3, 4)},
    **dict.fromkeys(
        (
            "marine_acoustic_msgs/msg/Dvl",
            "ds_sensor_msgs/msg/Dvl",
            "cola2_msgs/msg/DVL",
            "uuv_sensor_ros_plugins_msgs/msg/DVL",
            "waterlinked_a50_ros_driver/msg/DVL",
        ),
        _DVL,
    ),
}
"""Each supported type's parts of its row: name -> columns."""

_BODY_FIELDS = {
    "geometry_msgs/msg/TwistStamped": _xyz("twist.linear"),
    "geometry_msgs/msg/TwistWithCovarianceStamped": _xyz("twist.twist.linear"),
}


def field_names(kind: str, part: str) -> tuple[str, ...]:
    """The message fields of each column of a part of a type's row (:data:`LAYOUTS`), for a message."""
    columns = LAYOUTS[kind][part]
    if kind in FIELDS:
        return FIELDS[kind][columns]
    if part == "body":
        return _BODY_FIELDS.get(kind, _xyz("velocity"))
    if part == "beams":
        return tuple(f"beam {k} velocity" for k in range(1, 5))
    n = columns.stop - columns.start
    return tuple(f"{part} {k}" for k in range(1, n + 1))


LARGEST = 1e100
"""The largest magnitude a message's number may have (no sensor's comes near; its square and a sum
of squares stay finite, so no arithmetic on it overflows)."""


def require_finite(
    where: str, kind: str, part: str, values: np.ndarray, rows: np.ndarray | None = None
) -> None:
    """Refuse a message whose part ``part`` (M, C) of its row holds a NaN, an infinity or a number
    beyond :data:`LARGEST`, before
    any arithmetic on it: a LogError ``"<where>, message N: <field> is inf, not a finite number"``.

    Parameters
    ----------
    where : str
        The bag and topic, for the message (``"'x.bag': topic '/dvl' (dvl)"``).
    kind : str
        The messages' type.
    part : str
        The part of their rows (:data:`LAYOUTS`), which names the fields.
    values : numpy.ndarray
        The part's columns (M, C).
    rows : numpy.ndarray or None
        The messages checked (M,) bool, or the values checked (M, C) bool (a DVL's valid ones);
        None: all.

    Raises
    ------
    LogError
        At the first message (in the first column that has one) not finite.
    """
    names = field_names(kind, part)
    for c in range(values.shape[1]):
        with np.errstate(invalid="ignore"):
            bad = ~(np.abs(values[:, c]) <= LARGEST)
        if rows is not None:
            bad &= rows[:, c] if rows.ndim == 2 else rows
        if bad.any():
            m = int(np.argmax(bad))
            raise LogError(
                f"{where}, message {m + 1}: {names[c]} is {float(values[m, c])!r}, not a finite number "
                f"(within +-{LARGEST:g})"
            )


_SIZES = {"bool": 1, "byte": 1, "char": 1, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2, "int32": 4,
          "uint32": 4, "float32": 4, "int64": 8, "uint64": 8, "float64": 8}  # fmt: skip
_KINDS = {"f": "f", "i": "i", "u": "u", "b": "u", "c": "u"}  # float, int, uint, bool/byte, char
_STAMP = ("header.stamp.sec", "header.stamp.nanosec")


class _Unreadable(Exception):
    """A message whose bytes the decoder does not lay out (the per-message path reads it)."""


class _Layout:
    """Where the numbers sit in the bytes of the messages of one layout: the length prefixes that
    fix it (offset, value), and each wanted field's (offset, little-endian numpy dtype)."""

    def __init__(self, size: int, checks: list[tuple[int, int]], columns: list[tuple[int, str]]) -> None:
        self.size = size  # the messages' length [bytes]
        self.checks = checks
        self.columns = columns
        # the same as arrays, as tauvcore.logs.bags.scan.fixed_rows takes them
        self.check_at = np.array([at for at, _ in checks], dtype=np.int64)
        self.check_value = np.array([value for _, value in checks], dtype=np.int64)
        self.column_at = np.array([at for at, _ in columns], dtype=np.int64)
        self.column_kind = np.array([KINDS[dtype] for _, dtype in columns], dtype=np.int64)


def _walk(
    fielddefs: Any, kind: str, raw: bytes, cdr: bool, wanted: Sequence[str]
) -> tuple[list[tuple[int, int]], dict[str, tuple[int, str]]]:
    """The length prefixes (offset, value) of one serialised message ``raw`` of type ``kind`` and
    the offset and type of each ``wanted`` scalar field, following its definition: CDR (ROS 2,
    little-endian, each primitive aligned to its size after the 4-byte encapsulation header) or
    ROS 1 (packed). Raises _Unreadable for anything else."""
    base = 4 if cdr else 0
    pos = base
    checks: list[tuple[int, int]] = []
    found: dict[str, tuple[int, str]] = {}
    prefixes = {w.rsplit(".", i)[0] for w in wanted for i in range(w.count(".") + 1)}

    def align(size: int) -> None:
        nonlocal pos
        if cdr and size > 1:
            pos = base + -(-(pos - base) // size) * size

    def count() -> int:
        nonlocal pos
        align(4)
        if pos + 4 > len(raw):
            raise _Unreadable
        value = int.from_bytes(raw[pos : pos + 4], "little")
        checks.append((pos, value))
        pos += 4
        return value

    def skip(desc: Any, n: int) -> None:  # n elements of desc, not wanted
        nonlocal pos
        node, arg = int(desc[0]), desc[1]
        if node == 1 and arg[0] in _SIZES:
            if n:
                align(_SIZES[arg[0]])
                pos += n * _SIZES[arg[0]]
            return
        for _ in range(n):
            field(desc, None)

    def field(desc: Any, path: str | None) -> None:  # path: the field's, None where nothing is wanted
        nonlocal pos
        node, arg = int(desc[0]), desc[1]
        if node == 1:
            name = arg[0]
            if name == "string":
                length = count()  # CDR's counts the closing NUL
                pos += length
            elif name in _SIZES:
                align(_SIZES[name])
                if path is not None and path in wanted:
                    found[path] = (pos, f"<{_KINDS[name[0]]}{_SIZES[name]}")
                pos += _SIZES[name]
            else:
                raise _Unreadable  # wstring and the like
        elif node == 2:
            if arg not in fielddefs:
                raise _Unreadable
            for name, sub in fielddefs[arg][1]:
                full = name if path == "" else f"{path}.{name}"
                field(sub, full if path is not None and full in prefixes else None)
        else:
            sub, length = arg
            skip(sub, length if node == 3 else count())
        if pos > len(raw):
            raise _Unreadable

    field((2, kind), "")
    if pos > len(raw) or any(w not in found for w in wanted):
        raise _Unreadable
    return checks, found


class RawDecoder:
    """Reads the rows (:data:`FIELDS`) and header stamps of many messages of one type at once
    from their serialised bytes, without deserialising each (module docstring).

    Parameters
    ----------
    fielddefs : Mapping
        The typestore's definitions (``typestore.fielddefs``: type -> (constants, fields)).
    kind : str
        The messages' type, one of :data:`FIELDS`.
    cdr : bool
        True for ROS 2's CDR (sqlite3 and MCAP bags), False for ROS 1's serialisation.
    deserialize : Callable
        rosbags' deserialisation of one message's bytes, which each new layout is checked against.
    fields : tuple of str or None
        The row's fields, the first of ``FIELDS[kind]`` (:data:`IMU_RATES`); None: all of them.
    """

    def __init__(
        self,
        fielddefs: Any,
        kind: str,
        cdr: bool,
        deserialize: Callable[[bytes], Any],
        fields: tuple[str, ...] | None = None,
    ) -> None:
        self.fielddefs = fielddefs
        self.kind = kind
        self.cdr = cdr
        self.deserialize = deserialize
        self.fields = FIELDS[kind] if fields is None else fields
        self.extract = EXTRACT[kind] if fields is None else _fields(fields)  # a message -> its row
        self.stamped = "header" in {name for name, _ in fielddefs[kind][1]}
        self.wanted = self.fields + (_STAMP if self.stamped else ())
        self.layouts: dict[tuple[int, tuple[tuple[int, int], ...]], _Layout] = {}
        self.last: _Layout | None = None  # the layout of the messages read last

    def decode(self, raws: Sequence[bytes]) -> tuple[np.ndarray, np.ndarray | None] | None:
        """The rows (N, C) and header stamps [ns] (N,) of messages ``raws`` (None for a type
        without a header); None when any of them is not laid out as expected (a definition that
        differs, a truncated or big-endian message): the caller then reads each on its own.

        Parameters
        ----------
        raws : Sequence of bytes
            The messages' serialised bytes, in the topic's order.

        Returns
        -------
        tuple of numpy.ndarray and numpy.ndarray or None, or None
            The rows as :data:`EXTRACT` gives them (float64) and the stamps (int64).
        """
        n = len(raws)
        rows = np.empty((n, len(self.fields)))
        stamps = np.empty(n, dtype=np.int64) if self.stamped else None
        lengths = np.fromiter(map(len, raws), dtype=np.int64, count=n)
        groups = (
            [np.arange(n)]
            if n and (lengths == lengths[0]).all()
            else [np.flatnonzero(lengths == size) for size in np.unique(lengths)]
        )
        try:
            for index in groups:
                self._group(raws, index, rows, stamps)
        except _Unreadable:
            return None
        return rows, stamps

    def decode_chunk(
        self,
        chunk: np.ndarray,
        offset: np.ndarray,
        length: np.ndarray,
        rows: np.ndarray,
        stamps: np.ndarray,
        at: int,
    ) -> int:
        """Read messages in a chunk's bytes into ``rows`` and ``stamps`` from row ``at`` on
        (:func:`~tauvcore.logs.bags.scan.fixed_rows`), layout by layout, up to the first message that
        is not laid out as expected (which the caller reads on its own, with the rest).

        Parameters
        ----------
        chunk : numpy.ndarray
            The chunk's bytes (B,) uint8.
        offset : numpy.ndarray
            The messages' byte offsets in ``chunk`` (M,) int64, in the topic's order.
        length : numpy.ndarray
            Their lengths [bytes] (M,) int64.
        rows : numpy.ndarray
            Out: the rows (K, C) float64 as :data:`EXTRACT` gives them.
        stamps : numpy.ndarray
            Out: the header stamps [ns] (K,) int64; empty for a type without a header.
        at : int
            The row the first message goes to.

        Returns
        -------
        int
            How many messages, from the first, were read.
        """
        done, n = 0, offset.size
        while done < n:
            layout = self.last
            if layout is not None:
                done += fixed_rows(chunk, offset[done:], length[done:], layout.size, layout.check_at,
                                   layout.check_value, self.cdr, layout.column_at, layout.column_kind, rows,
                                   stamps, at + done)  # fmt: skip
                if done == n:
                    break
            start = int(offset[done])
            raw = chunk[start : start + int(length[done])]
            found = [
                lay for lay in self.layouts.values() if lay.size == raw.size and self._same(raw[None], lay)[0]
            ]
            try:
                self.last = found[0] if found else self._layout(raw.tobytes())
            except _Unreadable:
                break
            if not self._same(raw[None], self.last)[0]:
                break
        return done

    def _group(
        self, raws: Sequence[bytes], index: np.ndarray, rows: np.ndarray, stamps: np.ndarray | None
    ) -> None:
        """Messages ``index`` (all of one length) into ``rows`` and ``stamps``, layout by layout."""
        group = [raws[i] for i in index] if index.size < len(raws) else raws
        data = np.frombuffer(b"".join(group), dtype=np.uint8).reshape(index.size, -1)
        self._fill(data, index, rows, stamps)

    def _fill(self, data: np.ndarray, index: np.ndarray, rows: np.ndarray, stamps: np.ndarray | None) -> None:
        """Messages ``data`` (N, L) uint8 into ``rows`` and ``stamps`` at ``index`` (N,), layout
        by layout: the layout of the last block tried first, so a topic read block by block walks
        its definition once."""
        while index.size:
            layout = self.last if self.last is not None and self.last.size == data.shape[1] else None
            if layout is None or not self._same(data[:1], layout)[0]:
                layout = self._layout(data[0].tobytes())
            same = self._same(data, layout)
            if not same[0]:  # not even the message the layout was found from
                raise _Unreadable
            self.last = layout
            every = bool(same.all())
            take = index if every else index[same]
            rows_of = data if every else data[same]
            values = [_column(rows_of, offset, dtype) for offset, dtype in layout.columns]
            ncols = rows.shape[1]
            for c in range(ncols):
                rows[take, c] = values[c]
            if stamps is not None:
                stamps[take] = values[ncols].astype(np.int64) * 1_000_000_000 + values[ncols + 1].astype(
                    np.int64
                )
            if every:
                return
            index, data = index[~same], data[~same]

    def _same(self, data: np.ndarray, layout: _Layout) -> np.ndarray:
        """Which messages of ``data`` (N, L) uint8 are laid out as ``layout`` (N,) bool: the
        same length prefixes (and, in CDR, little-endian)."""
        same = np.ones(data.shape[0], dtype=bool)
        for offset, value in layout.checks:
            same &= _column(data, offset, "<u4") == value
        if self.cdr:  # little-endian CDR: the encapsulation header's second byte
            same &= data[:, 1] == 1
        return same

    def _layout(self, raw: bytes) -> _Layout:
        """The layout of messages laid out as ``raw``, found once and checked against rosbags'
        deserialisation of ``raw`` (the same row, the same stamp)."""
        if self.cdr and raw[:2] != b"\x00\x01":
            raise _Unreadable
        checks, found = _walk(self.fielddefs, self.kind, raw, self.cdr, self.wanted)
        key = (len(raw), tuple(checks))
        if key in self.layouts:
            return self.layouts[key]
        layout = _Layout(len(raw), checks, [found[w] for w in self.wanted])
        try:
            msg = self.deserialize(raw)
            want = self.extract(msg)
            stamp = (msg.header.stamp.sec, msg.header.stamp.nanosec) if self.stamped else ()
        except Exception:  # noqa: BLE001  (the per-message path names what is wrong)
            raise _Unreadable from None
        data = np.frombuffer(raw, dtype=np.uint8).reshape(1, -1)
        got = [_column(data, offset, dtype)[0] for offset, dtype in layout.columns]
        if not np.array_equal(
            np.array(got[: len(want)], dtype=float), np.array(want, dtype=float), equal_nan=True
        ):
            raise _Unreadable
        if [int(v) for v in got[len(want) :]] != [int(v) for v in stamp]:
            raise _Unreadable
        self.layouts[key] = layout
        return layout


def _column(data: np.ndarray, offset: int, dtype: str) -> np.ndarray:
    """Field at byte ``offset`` of each row of ``data`` (N, L) uint8, as ``dtype`` (N,)."""
    size = np.dtype(dtype).itemsize
    return np.ascontiguousarray(data[:, offset : offset + size]).view(dtype)[:, 0]


def _field(message: Any, path: str) -> Any:
    """The field at dotted ``path`` of ``message``."""
    for name in path.split("."):
        message = getattr(message, name)
    return message


def plugin_row(spec: BagMessage) -> Callable[[Any], tuple[float, ...]]:
    """A plug-in source's row of a message (its :class:`~tauvcore.aiding.source.BagMessage`): per
    field, a ``world_vector``'s x, y, z, a ``world_sigma``'s position variances (the covariance's
    diagonal entries 0, 7, 14), a ``scalar``'s value; the reader converts them
    (tauvcore.logs.bags.ros_reader)."""

    def row(m: Any) -> tuple[float, ...]:
        out: list[float] = []
        for f in spec.fields:
            value = _field(m, f.path)
            if f.kind == "world_vector":
                out.extend(float(c) for c in _vec(value))
            elif f.kind == "world_sigma":
                out.extend(float(value[i]) for i in (0, 7, 14))
            else:
                out.append(float(value))
        return tuple(out)

    return row
