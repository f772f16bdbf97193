"""The chunk-by-chunk read of a bag (tauvcore.logs.bags.scan) gives exactly what rosbags' walk message by
message gives: every topic's stamps, receive times and rows, on a ROS 1 bag (uncompressed, bz2,
lz4; small chunks), an MCAP file (uncompressed, zstd; a topic split across chunks) and a ROS 2
sqlite3 bag (read by rosbags); topics interleaved, ties of receive times, receive times that go
back, a topic of two message lengths; a corrupt chunk is one LogError line naming the file."""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tauvcore.logs.bags.ros_reader as reader_module
from tauvcore.logs import LogError
from tauvcore.logs.bags import BagMapping
from tauvcore.logs.bags.scan import NotScannedError
from tests.unit.helpers.bag_fixtures import make, store_for

N = 2500  # IMU and reference messages: more than one MCAP chunk of 1 MiB


def _messages(store: Any, ros1: bool) -> list[tuple[int, str, str, Any]]:
    """(receive time [ns], topic, type, message), interleaved, in the order written."""
    rng = np.random.default_rng(7)
    t0 = 1_700_000_000_000_000_000
    out: list[tuple[int, str, str, Any]] = []

    def header(ns: int, frame_id: str) -> Any:
        stamp = store.types["builtin_interfaces/msg/Time"](
            sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000
        )
        return make(
            store, "std_msgs/msg/Header", stamp=stamp, frame_id=frame_id, **({"seq": 1} if ros1 else {})
        )

    def vec(v: np.ndarray) -> Any:
        return make(store, "geometry_msgs/msg/Vector3", x=float(v[0]), y=float(v[1]), z=float(v[2]))

    def quat(q: np.ndarray) -> Any:
        return make(store, "geometry_msgs/msg/Quaternion", x=q[0], y=q[1], z=q[2], w=q[3])

    for k in range(N):
        ns = t0 + k * 10_000_000
        received = ns + int(rng.integers(0, 3_000_000))
        if k % 997 == 500:
            received -= 25_000_000  # received before the messages written before it
        elif k % 50 == 7:
            received = out[-2][0]  # received with the topic's message before: a tie
        frame = "imu_link_long" if k % 611 == 3 else "imu"  # another length, another layout
        imu = make(
            store,
            "sensor_msgs/msg/Imu",
            header=header(ns, frame),
            angular_velocity=vec(rng.normal(size=3)),
            linear_acceleration=vec(rng.normal(size=3)),
            orientation=quat(rng.normal(size=4)),
        )
        out.append((received, "/imu/data", "sensor_msgs/msg/Imu", imu))
        pose = make(
            store,
            "geometry_msgs/msg/Pose",
            position=make(
                store, "geometry_msgs/msg/Point", **dict(zip("xyz", rng.normal(size=3).tolist(), strict=True))
            ),
            orientation=quat(rng.normal(size=4)),
        )
        odom = make(
            store,
            "nav_msgs/msg/Odometry",
            header=header(ns, "odom"),
            child_frame_id="base_link",
            pose=make(store, "geometry_msgs/msg/PoseWithCovariance", pose=pose),
            twist=make(
                store,
                "geometry_msgs/msg/TwistWithCovariance",
                twist=make(store, "geometry_msgs/msg/Twist", linear=vec(rng.normal(size=3))),
            ),
        )
        out.append((received, "/odom", "nav_msgs/msg/Odometry", odom))  # the IMU's receive time: a tie
        if k % 10 == 0:
            out.append(
                (
                    ns + 1,
                    "/pressure",
                    "sensor_msgs/msg/FluidPressure",
                    make(
                        store, "sensor_msgs/msg/FluidPressure", header=header(ns, "p"), fluid_pressure=1e5 + k
                    ),
                )
            )
            beams = rng.normal(size=4).astype(np.float32)
            out.append(
                (
                    ns + 2,
                    "/dvl",
                    "marine_acoustic_msgs/msg/Dvl",
                    make(
                        store,
                        "marine_acoustic_msgs/msg/Dvl",
                        header=header(ns, "dvl"),
                        velocity=vec(rng.normal(size=3)),
                        num_good_beams=4,
                        beam_velocities_valid=True,
                        beam_velocity=beams,
                        beam_unit_vec=[vec(v) for v in np.eye(3)[[0, 1, 2, 0]]],
                    ),
                )
            )
    return out


def _write(path: Path, storage: str, compression: str) -> Path:
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2

    store = store_for(storage)
    if storage == "ros1":
        writer: Any = Writer1(path)
        if compression:
            writer.set_compression(getattr(Writer1.CompressionFormat, compression.upper()))
        writer.chunk_threshold = 64 * 1024  # many chunks
    else:
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path.with_suffix(""), version=9, storage_plugin=plugin)
        if compression:
            writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    serialize = store.serialize_ros1 if storage == "ros1" else store.serialize_cdr
    with writer:
        connections: dict[str, Any] = {}
        for received, topic, kind, msg in _messages(store, storage == "ros1"):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, kind, typestore=store)
            writer.write(connections[topic], received, serialize(msg, kind))
    if storage == "mcap":
        directory = path.with_suffix("")
        next(directory.glob("*.mcap")).rename(path)
        for leftover in directory.iterdir():
            leftover.unlink()
        directory.rmdir()
        return path
    return path if storage == "ros1" else path.with_suffix("")


def _by_rosbags(monkeypatch: pytest.MonkeyPatch) -> None:
    """Read as rosbags alone does: its own ROS 1 reader, message by message."""
    from rosbags.rosbag1 import Reader as Reader1

    def unusual(*_: Any) -> None:
        raise NotScannedError

    monkeypatch.setattr(reader_module, "read_chunked", unusual)
    monkeypatch.setattr(reader_module, "Ros1Reader", Reader1)


@pytest.mark.parametrize(("storage", "compression", "name"), [
    ("ros1", "", "m.bag"), ("ros1", "bz2", "m.bag"), ("ros1", "lz4", "m.bag"),
    ("mcap", "", "m.mcap"), ("mcap", "zstd", "m.mcap"), ("sqlite3", "", "m.db3"),
])  # fmt: skip
def test_the_chunked_read_equals_rosbags_message_by_message(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, storage: str, compression: str, name: str
) -> None:
    bag = _write(tmp_path / name, storage, compression)
    calls: list[bool] = []
    real = reader_module.read_chunked

    def spy(*args: Any) -> None:
        try:
            real(*args)
        except NotScannedError:
            calls.append(False)
            raise
        calls.append(True)

    monkeypatch.setattr(reader_module, "read_chunked", spy)
    _, fast, _ = reader_module.read_topics(bag, BagMapping())
    assert calls == [storage != "sqlite3"]  # sqlite3: rosbags'
    with monkeypatch.context() as m:
        _by_rosbags(m)
        _, slow, _ = reader_module.read_topics(bag, BagMapping())
    assert sorted(fast) == sorted(slow) == ["/dvl", "/imu/data", "/odom", "/pressure"]
    for topic in slow:
        assert fast[topic].count == slow[topic].count == (N if topic in ("/imu/data", "/odom") else N // 10)
        for field in ("stamps", "received", "rows"):
            a, b = getattr(fast[topic], field), getattr(slow[topic], field)
            assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), (topic, field)
    received = slow["/imu/data"].received
    assert (np.diff(received) >= 0).all() and not (np.diff(slow["/imu/data"].stamps) >= 0).all()


def _chunk_data(bag: Path) -> int:
    """The byte offset of the first chunk's (uncompressed) records in an MCAP file."""
    from rosbags.rosbag2.storage_mcap import McapReader

    storage = McapReader(bag)
    storage.open()
    first = min(storage.chunks, key=lambda c: c.chunk_start_offset)
    storage.close()
    return first.chunk_start_offset + 9 + 40 + len(first.compression)


@pytest.mark.parametrize("name", ["m.bag", "m.mcap"])
def test_a_corrupt_chunk_is_one_line_naming_the_file(tmp_path: Path, name: str) -> None:
    bag = _write(tmp_path / name, "ros1" if name.endswith(".bag") else "mcap", "")
    data = bytearray(bag.read_bytes())
    if name.endswith(".bag"):  # a message record's 'op' field longer than its header
        at = data.index(struct.pack("<I", 4) + b"op=\x02", 5000)
        data[at : at + 4] = struct.pack("<I", 1 << 30)
    else:  # the first record's length past the chunk's end
        at = _chunk_data(bag) + 1
        data[at : at + 8] = struct.pack("<Q", 1 << 40)
    bad = tmp_path / f"bad{bag.suffix}"
    bad.write_bytes(bytes(data))
    with pytest.raises(LogError) as error:
        reader_module.read_topics(bad, BagMapping())
    message = str(error.value)
    assert "\n" not in message and str(bad.name) in message and "cannot be read" in message, message
