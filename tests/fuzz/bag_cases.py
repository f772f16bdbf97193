"""Hostile ROS bags and bag mappings for ``tauv replay``, ``tauv log info`` and ``tauv log convert``:
small valid bases (a ROS 1 bag, an MCAP file of per-beam DVL messages, an MCAP file of a twist DVL,
each with its own mapping beside it), and one seeded generator per class that breaks a copy of a
base in one way. A generator takes a ``numpy.random.Generator``: the same cases on every run.

Classes: bytes (truncated at a random byte, bytes flipped, a record's length made huge, an MCAP
chunk's CRC made wrong), special files (a FIFO, a link to /dev/zero, a symbolic link loop, a
dangling link, a directory named as a bag, an empty file, the magic alone), wrong formats (an
MCAP file named ``.bag``, a ROS 1 bag named ``.mcap``, random bytes), bad mappings (a topic used
twice, a form that does not fit the type, empty or unknown topics, bad keys and values,
``msg_paths`` that cannot be read), non-finite fields (NaN or an infinity in a sensor's number)
and stamps (going back, repeated, a jump of years). Each states which outcome is allowed:
refuse (exit 2), or either (exit 0 or 2; a flipped byte may fall in a number).
"""

from __future__ import annotations

import os
import shutil
import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REFUSE, EITHER = "refuse", "either"
MAPPING = 'frame = "frd_ned"\n\n[config.earth]\nmodel = "flat"\n'
"""Each base's own mapping: write_bag's FRD/NED topics of a flat-earth mission."""
TABLE_COLUMNS = {
    "imu": ("gyro_x_rps", "gyro_z_rps", "accel_x_mps2", "accel_z_mps2"),
    "depth": ("depth_m",),
    "reference": ("north_m", "down_m", "vel_east_mps"),
}
"""The columns a non-finite case may spoil, by table (the DVL's: by its form; an angle is written
as a quaternion, which a non-finite angle has none of)."""


@dataclass(frozen=True)
class Base:
    """A valid bag and the tables it was written from."""

    name: str  # ros1, mcap, twist
    path: Path  # the bag
    tables: dict
    dvl_type: str
    A_b: np.ndarray


@dataclass(frozen=True)
class Case:
    """One hostile input: what to run it as and what it must do."""

    target: str  # the bag's path (relative to the case directory)
    outcome: str  # REFUSE or EITHER
    names: tuple[str, ...]  # on exit 2 the message names one of these
    what: str  # the mutation, for a failure's report
    mapping: str | None = None  # a --bag-mapping file, if the case gives one
    listed: bool = False  # what ``log info`` (which lists topics, reads no values, checks no [config]) may accept


def build_bases(root: Path, duration_s: float = 2.0) -> list[Base]:
    """Three small valid bags (``duration_s`` of a simulated mission) in ``root``."""
    from tests.unit.helpers.bag_fixtures import mission_config, mission_tables, write_bag

    root.mkdir(parents=True, exist_ok=True)
    config = mission_config(duration_s=duration_s)
    beams, body = mission_tables(config)
    bases = []
    for name, storage, tables, dvl in (
        ("ros1", "ros1", beams, "marine_acoustic_msgs/msg/Dvl"),
        ("mcap", "mcap", beams, "marine_acoustic_msgs/msg/Dvl"),
        ("twist", "mcap", body, "geometry_msgs/msg/TwistWithCovarianceStamped"),
    ):
        path = write_bag(root / f"{name}.{'bag' if storage == 'ros1' else 'mcap'}", storage, tables, dvl,
                         config.dvl.A_b)
        bases.append(Base(name, path, tables, dvl, config.dvl.A_b))
    return bases


def _copy(base: Base, case_dir: Path, name: str | None = None) -> Path:
    """The base bag copied into ``case_dir`` with its own mapping beside it."""
    bag = case_dir / (name or base.path.name)
    shutil.copyfile(base.path, bag)
    bag.with_suffix(".toml").write_text(MAPPING)
    return bag


def _case(bag: Path, outcome: str, what: str, *names: str, mapping: str | None = None, listed: bool = False) -> Case:
    return Case(bag.name, outcome, (bag.name, *names), what, mapping, listed)


# --------------------------------------------------------------------------------------- bytes
def _mcap_records(data: bytes) -> list[tuple[int, int, int]]:
    """(position, opcode, length) of an MCAP file's records after its magic, up to the footer."""
    out, pos = [], 8
    while pos + 9 <= len(data) - 8:
        op, length = data[pos], struct.unpack_from("<Q", data, pos + 1)[0]
        out.append((pos, op, length))
        if op == 0x02 or pos + 9 + length > len(data):
            break
        pos += 9 + length
    return out


def _ros1_records(data: bytes) -> list[int]:
    """The positions of a ROS 1 bag's records (each a header length, header, data length, data)."""
    out, pos = [], 13
    while pos + 8 <= len(data):
        out.append(pos)
        header = struct.unpack_from("<I", data, pos)[0]
        if pos + 4 + header + 4 > len(data):
            break
        pos += 4 + header + 4 + struct.unpack_from("<I", data, pos + 4 + header)[0]
    return out


def truncated(rng: np.random.Generator, base: Base, case_dir: Path) -> Case:
    bag = _copy(base, case_dir)
    data = bag.read_bytes()
    cut = int(rng.integers(1, len(data)))
    bag.write_bytes(data[:cut])
    return _case(bag, EITHER, f"cut at byte {cut} of {len(data)}")


def flipped(rng: np.random.Generator, base: Base, case_dir: Path) -> Case:
    bag = _copy(base, case_dir)
    data = bytearray(bag.read_bytes())
    n = int(rng.integers(1, 9))
    where = rng.integers(0, len(data), n)
    for at in where:
        data[at] ^= int(rng.integers(1, 256))
    bag.write_bytes(bytes(data))
    return _case(bag, EITHER, f"bytes flipped at {sorted(where.tolist())}")


def huge_length(rng: np.random.Generator, base: Base, case_dir: Path) -> Case:
    bag = _copy(base, case_dir)
    data = bytearray(bag.read_bytes())
    values = [2**64 - 1, 2**63, 1 << 40, 2**32 - 1, len(data) + 1]
    value = values[int(rng.integers(0, len(values)))]
    if base.name == "ros1":
        at = int(rng.choice(_ros1_records(bytes(data))))
        data[at : at + 4] = struct.pack("<I", min(value, 2**32 - 1))
    else:
        at = int(rng.choice([p for p, _, _ in _mcap_records(bytes(data))])) + 1
        data[at : at + 8] = struct.pack("<Q", value)
    bag.write_bytes(bytes(data))
    return _case(bag, EITHER, f"record length at byte {at} set to {value}")


def wrong_crc(rng: np.random.Generator, base: Base, case_dir: Path) -> Case:
    bag = _copy(base, case_dir, "mcap.mcap" if base.name == "ros1" else None)
    if base.name == "ros1":  # an MCAP case either way
        shutil.copyfile(base.path.with_name("mcap.mcap"), bag)
    data = bytearray(bag.read_bytes())
    chunks = [p for p, op, _ in _mcap_records(bytes(data)) if op == 0x06]
    at = int(rng.choice(chunks)) + 9 + 24
    old = struct.unpack_from("<I", data, at)[0]
    new = (old ^ int(rng.integers(1, 2**32))) or 1
    data[at : at + 4] = struct.pack("<I", new)
    bag.write_bytes(bytes(data))
    return _case(bag, REFUSE if old else EITHER, f"chunk CRC at byte {at}: {old:#x} -> {new:#x}")


# ------------------------------------------------------------------------------- special files
def special(rng: np.random.Generator, base: Base, case_dir: Path) -> Case:
    kind = str(rng.choice(["fifo", "zero", "loop", "dangling", "directory", "empty", "magic", "metadata"]))
    suffix = str(rng.choice([".bag", ".mcap"]))
    bag = case_dir / f"s{suffix}"
    if kind == "fifo":
        os.mkfifo(bag)
    elif kind == "zero":
        bag.symlink_to("/dev/zero")
    elif kind == "loop":
        bag.symlink_to(bag.name)
    elif kind == "dangling":
        bag.symlink_to("gone" + suffix)
    elif kind == "directory":
        bag.mkdir()
        (bag / "notes.txt").write_text("not a bag\n")
    elif kind == "empty":
        bag.write_bytes(b"")
    elif kind == "magic":
        bag.write_bytes(b"\x89MCAP0\r\n" if suffix == ".mcap" else b"#ROSBAG V2.0\n")
    else:  # a ROS 2 directory whose metadata.yaml is not a file, or not rosbag2's
        bag = case_dir / "run"
        bag.mkdir()
        meta = bag / "metadata.yaml"
        choice = int(rng.integers(0, 3))
        if choice == 0:
            os.mkfifo(meta)
        elif choice == 1:
            meta.write_text(str(rng.choice(["rosbag2_bagfile_information: x\n", "[1, 2\n", "a: {b: c}\n",
                                            "rosbag2_bagfile_information: {version: 9}\n"])))
        else:
            meta.symlink_to("/dev/zero")
        return Case("run", REFUSE, ("metadata.yaml", "run"), f"ROS 2 directory, metadata.yaml case {choice}")
    return _case(bag, REFUSE, kind)


def wrong_format(rng: np.random.Generator, base: Base, case_dir: Path) -> Case:
    kind = int(rng.integers(0, 3))
    if kind == 0:
        bag = case_dir / "x.bag"
        shutil.copyfile(base.path.with_name("mcap.mcap"), bag)
    elif kind == 1:
        bag = case_dir / "x.mcap"
        shutil.copyfile(base.path.with_name("ros1.bag"), bag)
    else:
        bag = case_dir / str(rng.choice(["x.bag", "x.mcap"]))
        bag.write_bytes(rng.integers(0, 256, int(rng.integers(1, 4096)), dtype=np.uint8).tobytes())
    return _case(bag, REFUSE, f"wrong format {kind}")


# -------------------------------------------------------------------------------- bad mappings
BAD_MAPPINGS = [
    '[dvl]\nwater_track_topic = "/dvl"\n',
    '[dvl]\ntopic = "/dvl"\nwater_track_topic = "/dvl"\n',
    '[imu]\ntopic = ""\n',
    '[imu]\ntopic = "/nowhere"\n',
    '[imu]\ntopic = 3\n',
    '[dvl]\ntopic = "/imu/data"\n',
    '[dvl]\nwater_track_topic = ""\n',
    '[dvl]\nmounting_rpy_deg = [0, 0]\n',
    '[dvl]\nmounting_rpy_deg = [0, 0, inf]\n',
    '[depth]\noffset_s = nan\n',
    '[depth]\nwater_density_kgpm3 = 1e9\n',
    '[imu]\nfrm = "flu_enu"\n',
    'time = "later"\n',
    'msg_paths = ["missing/msg/X.msg"]\n',
    'msg_paths = ["x.msg"]\n',
    '[reference]\ntopic = ""\n[attitude]\ntopic = ""\n',
    '[imu]\nvelocity_topic = "/imu/data"\n',
    '[config.dvl]\nnoise_mps = -1\n',
    '[usbl]\ntopic = "/odom"\n',
    '[reference]\norientation_topic = "/odom"\n',
]
"""Mappings each wrong in one way (laid under a valid mapping's lines)."""
TWIST_MAPPINGS = ['[dvl]\nform = "beams"\n']


def bad_mapping(rng: np.random.Generator, base: Base, case_dir: Path) -> Case:
    bag = _copy(base, case_dir)
    choices = BAD_MAPPINGS + (TWIST_MAPPINGS if base.name == "twist" else [])
    text = choices[int(rng.integers(0, len(choices)))]
    own = bool(rng.integers(0, 2))
    mapping = bag.with_suffix(".toml") if own else case_dir / "given.toml"
    mapping.write_text(MAPPING + text if text.startswith("[") else text + MAPPING)  # top-level keys first
    if "msg_paths" in text and rng.integers(0, 2):
        fifo = case_dir / "missing" / "msg" / "X.msg"
        fifo.parent.mkdir(parents=True)
        os.mkfifo(fifo)
    return _case(bag, REFUSE, f"mapping {text!r}", mapping.name, mapping=None if own else mapping.name, listed=True)


# ------------------------------------------------------------------------- rewritten from tables
def _rewrite(base: Base, case_dir: Path, tables: dict) -> Path:
    from tests.unit.helpers.bag_fixtures import write_bag

    bag = case_dir / base.path.name
    storage = "ros1" if base.name == "ros1" else "mcap"
    with np.errstate(invalid="ignore", over="ignore"):  # the writer's arithmetic on the spoilt numbers
        write_bag(bag, storage, tables, base.dvl_type, base.A_b)
    bag.with_suffix(".toml").write_text(MAPPING)
    return bag


def _copy_tables(base: Base) -> dict:
    return {t: {c: np.array(v, copy=True) for c, v in cols.items()} for t, cols in base.tables.items()}


def non_finite(rng: np.random.Generator, base: Base, case_dir: Path) -> Case:
    tables = _copy_tables(base)
    dvl = ("vel_x_mps", "vel_y_mps") if base.name == "twist" else ("beam1_mps", "beam3_mps")
    options = [(t, c) for t, cs in TABLE_COLUMNS.items() for c in cs if tables[t][c].size] + [("dvl", c) for c in dvl] * 3
    table, column = options[int(rng.integers(0, len(options)))]
    row = int(rng.integers(0, tables[table][column].size))
    value = float(rng.choice([np.inf, -np.inf, np.nan]))
    if table == "dvl" and base.name != "twist" and np.isnan(value):
        value = np.inf  # a per-beam NaN is a beam that did not return
    tables[table][column][row] = value
    bag = _rewrite(base, case_dir, tables)
    return _case(bag, REFUSE, f"{table}.{column} row {row + 1} = {value}", listed=True)


def stamps(rng: np.random.Generator, base: Base, case_dir: Path) -> Case:
    tables = _copy_tables(base)
    table = str(rng.choice(["imu", "dvl", "depth", "reference", "attitude"]))
    if tables[table]["t_s"].size < 3:
        table = "imu"
    t = tables[table]["t_s"]
    kind = str(rng.choice(["backwards", "duplicate", "huge", "negative"]))
    k = int(rng.integers(1, t.size - 1))
    if kind == "backwards":
        t[k] = t[k - 1] - float(rng.uniform(0.001, 0.5))
    elif kind == "duplicate":
        t[k] = t[k - 1]
    elif kind == "huge":
        t[k:] += float(rng.choice([1e5, 3e7, 1e8]))
    else:
        t[k] = -float(rng.uniform(1.0, 1e6))
    bag = _rewrite(base, case_dir, tables)
    return _case(bag, EITHER, f"{table} stamps {kind} at row {k + 1}")


@dataclass(frozen=True)
class HostileClass:
    name: str
    make: Callable[[np.random.Generator, Base, Path], Case]
    weight: int = 1


CLASSES = [
    HostileClass("truncated", truncated, 3),
    HostileClass("flipped_bytes", flipped, 3),
    HostileClass("huge_length", huge_length, 2),
    HostileClass("wrong_crc", wrong_crc, 1),
    HostileClass("special_file", special, 2),
    HostileClass("wrong_format", wrong_format, 1),
    HostileClass("bad_mapping", bad_mapping, 3),
    HostileClass("non_finite", non_finite, 2),
    HostileClass("stamps", stamps, 2),
]
"""Each class of hostile bag, weighted by how many cases it gets."""
