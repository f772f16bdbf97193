"""Results as MCAP: a run's or a replay's estimates, 1-sigma, errors, innovations, truth and
events as ROS 2 messages in one ``.mcap`` file, which Foxglove and PlotJuggler open beside the
user's own bag (``tauv run --mcap``, ``tauv replay --mcap``, the dashboard's MCAP download).

Written with rosbags (a dependency already: it reads the bags ``tauv replay`` takes) as a ROS 2
bag of MCAP storage whose ``.mcap`` file is then moved to the output: every message is CDR with
its ``ros2msg`` schema inside the file, so a viewer needs no ROS install and no message package.
Topics (``<method>`` as ``config.run.methods`` names it, ``<source>`` as the update records do):

- ``/tauv/<method>/odometry`` (nav_msgs/msg/Odometry): the estimate in REP-103's frames: position
  [m] east, north, up from the sea-surface point above the start (``header.frame_id`` "tauv_enu"),
  orientation body forward-left-up to east-north-up, ``twist.linear`` the velocity in the body
  frame FLU (``child_frame_id`` "base_link") [m/s]; the angular velocity is not estimated (NaN).
  The position's covariance is the filter's own horizontal block (``MethodResult.pos_cov_ne_m2``:
  P_EE, P_EN and P_NN in ENU's x and y) with the vertical variance the trace leaves (the filter
  records sqrt(trace P_pos)); a family without that record (Yoo 2014's) shares the trace equally,
  sigma^2 / 3 per axis. The other diagonals share each block's trace equally among its axes (the
  filter records sqrt(trace P_vel), the tilt's sqrt(P_NN + P_EE) and the heading's sqrt(P_DD), not
  the axes apart): velocity sigma^2 / 3 per axis, roll and pitch tilt^2 / 2, yaw heading^2
  [rad^2]; the other off-diagonal terms are zero.
- ``/tauv/<method>/sigma`` (tauv_msgs/msg/Sigma): the filter's own 1-sigma as ``tauv run --json``
  names them (``pos_sigma_m``, ``vel_sigma_mps``, ``att_sigma_deg``, ``tilt_sigma_deg``,
  ``heading_sigma_deg``).
- ``/tauv/<method>/error`` (tauv_msgs/msg/Error): the errors against the truth or the log's
  reference (``pos_err_m`` ... ``heading_err_deg``, ``nees``), NaN where a log cannot judge them.
- ``/tauv/<method>/innovations/<source>`` (tauv_msgs/msg/Innovation): every update of the source:
  observation, innovation and its variance per row, the rows fused and rejected by the gate, the
  test ratio, NIS before the gate with its degrees of freedom, and the update's flags (``valid``,
  ``fused``, ``rejected``, ``unusable``); a DVL's ping also its beams returned, its mode (0 coast,
  1 loose, 2 partial, 3 tight; -1 for other sources) and whether the velocity was reset after a
  lock-out.
- ``/tauv/<method>/smoothed/odometry``, ``.../smoothed/sigma``, ``.../smoothed/error``: the
  fixed-interval smoother's, when the run smoothed.
- ``/tauv/truth/odometry`` (nav_msgs/msg/Odometry, no covariance): the simulation's truth, or the
  log's reference, at the output epochs (a log without a reference: none).
- ``/tauv/events`` (tauv_msgs/msg/Event): each event (tauvcore.eval.events) stamped at its start.

Every message's log time, publish time and ``header.stamp`` is the mission time plus ``origin_s``:
0 for a simulation (the file starts at the epoch 1970-01-01), a log's first IMU time for a replay
(a log directory's own clock, so the results line up with the log; a bag's times as its reader
keeps them, from its first IMU message). Of a Monte Carlo, run 0.

The fixed-size messages (all but the events) are packed with numpy a chunk at a time
(:class:`CdrLayout`, the same bytes as rosbags' serializer: tests/unit/app/test_mcap.py), so a
long mission costs little more than the file's writing; memory holds one chunk of messages.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from app.reports.files import new_file_mode
from tauvcore.config import Config
from tauvcore.engine.results import MethodResult, UpdateRecord

MAGIC = b"\x89MCAP0\r\n"
"""The first (and last) 8 bytes of every MCAP file."""
FRAME_ID = "tauv_enu"
"""The odometry's world frame: east, north, up from the sea-surface point above the start."""
CHILD_FRAME_ID = "base_link"
"""The odometry's body frame: forward, left, up (REP-103)."""
ODOMETRY = "nav_msgs/msg/Odometry"

MSG_DEFINITIONS: dict[str, str] = {
    "tauv_msgs/msg/Sigma": """\
# the filter's own 1-sigma at an output epoch (tauv run --json's names and units)
std_msgs/Header header
float64 pos_sigma_m        # sqrt(trace P_pos)
float64 vel_sigma_mps      # sqrt(trace P_vel)
float64 att_sigma_deg      # of the misalignment's norm
float64 tilt_sigma_deg     # sqrt(P_NN + P_EE) of the misalignment (roll, pitch)
float64 heading_sigma_deg  # sqrt(P_DD) of the misalignment
""",
    "tauv_msgs/msg/Error": """\
# the errors against the truth or the log's reference at an output epoch (NaN: not known)
std_msgs/Header header
float64 pos_err_m
float64 vel_err_mps
float64 att_err_deg
float64 tilt_err_deg
float64 heading_err_deg
float64 nees               # of the full state
""",
    "tauv_msgs/msg/Innovation": """\
# one update of an aiding source (tauvcore.engine.results.UpdateRecord), rows in the source's order
std_msgs/Header header
float64[] z                # the observation, in the source's units
float64[] innovation       # z - h(x)
float64[] innovation_var   # the diagonal of S
bool[] fused_rows
bool[] rejected_rows       # refused by the gate
float64 test_ratio         # max_i nu_i^2 / (gate^2 S_ii)
float64 nis                # over the active rows, before the gate
int32 nis_dof
bool valid                 # the source produced a measurement
bool fused
bool rejected              # the gate refused every row
bool unusable              # S not finite or not positive definite
bool[] beams_available     # a DVL's beams that returned (empty for other sources)
int32 mode                 # a DVL's: 0 coast, 1 loose, 2 partial, 3 tight; -1 other sources
bool reset                 # a DVL's velocity reset to this ping after a lock-out
""",
    "tauv_msgs/msg/Event": """\
# an event of the run (tauvcore.eval.events), stamped at its start
std_msgs/Header header
string kind
float64 start_s            # mission time [s]
float64 end_s              # equal to start_s for a moment's event
string method              # empty: the mission's or the sensor's own
uint8[] beams              # the DVL beams concerned (1-4), if any
string text
string source              # the aiding source of a gate rejection; empty otherwise
""",
}
"""The messages of ours, as ``.msg`` text (the file carries them as each topic's schema)."""

# -- CDR packing ---------------------------------------------------------------------------------
# A field of a fixed-size message: (name, kind, argument). Kinds: "i4", "u4", "f8", "u1" (a bool or
# uint8) scalars; "str" a string whose value (the argument) is the same in every message; "f8*N" /
# "u1*N" a fixed array of N (argument N); "f8[]" / "u1[]" a sequence, its length N (the argument) the
# same in every message of a topic.
Field = tuple[str, str, Any]


class CdrLayout:
    """The byte layout of a message type whose every message on a topic has the same size (its
    strings and sequence lengths fixed), in ROS 2's CDR (little-endian, XCDR1: each primitive
    aligned to its size from the start of the payload, after the 4-byte encapsulation header):
    a numpy structured dtype, so a chunk of messages is packed in a few array operations."""

    HEADER = b"\x00\x01\x00\x00"  # CDR, little-endian, no options

    def __init__(self, fields: Sequence[Field]) -> None:
        names: list[str] = []
        formats: list[Any] = []
        offsets: list[int] = []
        self.constants: dict[str, Any] = {}
        self.empty: set[str] = set()  # the sequences of length 0: no elements to fill
        end = 0

        def place(name: str, fmt: Any, size: int, align: int) -> None:
            nonlocal end
            end += -end % align
            names.append(name)
            formats.append(fmt)
            offsets.append(end)
            end += size

        for name, kind, arg in fields:
            if kind == "str":
                data = arg.encode("utf-8") + b"\x00"
                place(f"{name}.len", "<u4", 4, 4)
                place(name, f"S{len(data)}", len(data), 1)
                self.constants.update({f"{name}.len": len(data), name: data})
            elif kind.endswith("[]"):
                place(f"{name}.len", "<u4", 4, 4)
                self.constants[f"{name}.len"] = arg
                elem = kind[:-2]
                if arg:
                    place(name, (f"<{elem}", (arg,)), arg * int(elem[1]), int(elem[1]))
                else:
                    self.empty.add(name)
            elif "*" in kind:
                elem = kind.split("*")[0]
                place(name, (f"<{elem}", (arg,)), arg * int(elem[1]), int(elem[1]))
            else:
                place(name, f"<{kind}", int(kind[1]), int(kind[1]))
        self.dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": end})

    def pack(self, count: int, values: dict[str, Any]) -> list[bytes]:
        """``count`` messages, each as CDR bytes, from ``values``: field name -> (count,) or
        (count, N) array, or one value for every message; the constant fields filled here."""
        rows = np.zeros(count, dtype=self.dtype)
        for name, value in {**self.constants, **values}.items():
            if name not in self.empty:
                rows[name] = value
        raw = rows.tobytes()
        size = self.dtype.itemsize
        return [self.HEADER + raw[k * size : (k + 1) * size] for k in range(count)]


def _header(frame_id: str) -> list[Field]:
    return [("sec", "i4", None), ("nanosec", "u4", None), ("frame_id", "str", frame_id)]


def odometry_layout() -> CdrLayout:
    """nav_msgs/msg/Odometry in :data:`FRAME_ID` and :data:`CHILD_FRAME_ID`."""
    return CdrLayout(
        [
            *_header(FRAME_ID),
            ("child_frame_id", "str", CHILD_FRAME_ID),
            ("position", "f8*3", 3),
            ("orientation", "f8*4", 4),
            ("pose_covariance", "f8*36", 36),
            ("linear", "f8*3", 3),
            ("angular", "f8*3", 3),
            ("twist_covariance", "f8*36", 36),
        ]
    )


def scalar_fields(type_name: str) -> list[str]:
    """The float64 fields of tauv_msgs/msg/Sigma or Error, in order: each the MethodResult field
    of that name."""
    return [
        line.split()[1] for line in MSG_DEFINITIONS[type_name].splitlines() if line.startswith("float64 ")
    ]


def scalars_layout(type_name: str) -> CdrLayout:
    """tauv_msgs/msg/Sigma or Error: a header and float64 fields."""
    return CdrLayout([*_header(""), *((name, "f8", None) for name in scalar_fields(type_name))])


def innovation_layout(rows: int, beams: int) -> CdrLayout:
    """tauv_msgs/msg/Innovation of a source with ``rows`` measurement rows (``beams``: 4 for a
    DVL's bottom-track record, else 0)."""
    return CdrLayout(
        [
            *_header(""),
            *((name, "f8[]", rows) for name in ("z", "innovation", "innovation_var")),
            *((name, "u1[]", rows) for name in ("fused_rows", "rejected_rows")),
            ("test_ratio", "f8", None),
            ("nis", "f8", None),
            ("nis_dof", "i4", None),
            *((name, "u1", None) for name in ("valid", "fused", "rejected", "unusable")),
            ("beams_available", "u1[]", beams),
            ("mode", "i4", None),
            ("reset", "u1", None),
        ]
    )


def typestore() -> Any:
    """ROS 2's standard message types and :data:`MSG_DEFINITIONS` (rosbags.typesys)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.LATEST)
    types: dict[str, Any] = {}
    for name, text in MSG_DEFINITIONS.items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


# -- frames ----------------------------------------------------------------------------------------
T_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""NED to ENU (and back): x and y swap, z flips."""
D_FLU = np.diag([1.0, -1.0, -1.0])
"""FRD to FLU (and back)."""


def odometry_values(
    pos_n: np.ndarray, vel_n: np.ndarray | None, C_nb: np.ndarray | None
) -> dict[str, np.ndarray]:
    """The odometry's position (ENU), orientation (x, y, z, w: FLU to ENU, ``T C_nb D``) and body
    velocity (FLU, ``D C_nb^T v_n``) from NED positions (K, 3), velocities (K, 3) and attitudes
    (K, 3, 3); NaN where a part is unknown."""
    from scipy.spatial.transform import Rotation

    k = len(pos_n)
    values = {"position": pos_n @ T_ENU.T, "angular": np.full((k, 3), np.nan)}
    orientation = np.full((k, 4), np.nan)
    linear = np.full((k, 3), np.nan)
    if C_nb is not None:
        known = np.isfinite(C_nb).all(axis=(1, 2))
        if known.any():
            orientation[known] = Rotation.from_matrix(T_ENU @ C_nb[known] @ D_FLU).as_quat()
        if vel_n is not None:
            linear = np.einsum("im,kjm,kj->ki", D_FLU, C_nb, vel_n)
    values.update(orientation=orientation, linear=linear)
    return values


def _covariance(sigma: Sequence[np.ndarray], shares: Sequence[float]) -> np.ndarray:
    """(K, 36) row-major 6x6 covariances: diagonal j = sigma_j^2 * share (module docstring)."""
    cov = np.zeros((len(sigma[0]), 36))
    for j, (s, share) in enumerate(zip(sigma, shares, strict=True)):
        cov[:, 7 * j] = np.square(s) * share
    return cov


def _horizontal_covariance(cov: np.ndarray, p_ne_m2: np.ndarray, pos_sigma_m: np.ndarray) -> None:
    """Write the filter's horizontal position covariance ``p_ne_m2`` (K, 3: P_NN, P_NE, P_EE
    [m^2]) into the pose covariances ``cov`` (K, 36; ENU: x east, y north, z up), and the vertical
    variance as what the trace ``pos_sigma_m``^2 leaves (P_DD = trace - P_NN - P_EE, at least 0)."""
    p_nn, p_ne, p_ee = p_ne_m2[:, 0], p_ne_m2[:, 1], p_ne_m2[:, 2]
    cov[:, 0] = p_ee
    cov[:, 1] = cov[:, 6] = p_ne
    cov[:, 7] = p_nn
    cov[:, 14] = np.maximum(np.square(pos_sigma_m) - p_nn - p_ee, 0.0)


def stamps(t_s: np.ndarray, origin_ns: int) -> np.ndarray:
    """Mission times [s] (K,) as integer nanoseconds since the epoch, ``origin_ns`` added."""
    return np.round(np.asarray(t_s, dtype=np.float64) * 1e9).astype(np.int64) + origin_ns


class McapResults:
    """The MCAP file of a run, fed chunk by chunk (module docstring).

    Parameters
    ----------
    path : str
        The output file (its directory must be writable; checked before the run). The bag is
        written in a temporary directory beside it and its ``.mcap`` renamed to ``path`` by
        :meth:`finish`; :meth:`discard` removes it, ``path`` untouched.
    config : Config
        The run's configuration (its output rate picks the truth's rows).
    origin_s : float
        Added to the mission time in every stamp [s]: 0 for a simulation, a log's first IMU time.
    run : int
        The run written (of a Monte Carlo's R).
    """

    def __init__(self, path: str, config: Config, origin_s: float = 0.0, run: int = 0) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        self.path = path
        self.run = run
        self.step = max(1, round(config.imu.rate_hz / config.filter.output_rate_hz))
        self.origin_ns = round(origin_s * 1e9)
        self.spool = tempfile.mkdtemp(prefix=".tauv-", suffix=".mcap.parts", dir=os.path.dirname(path) or ".")
        self.bag = Path(self.spool) / "results"
        self.store = typestore()
        self.writer = Writer(self.bag, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.connections: dict[str, Any] = {}
        self.layouts: dict[str, CdrLayout] = {}
        self.counts: dict[str, int] = {}
        self.events = StreamedEvents(config, run)  # written at the end (spans need every ping)

    def _topic(self, topic: str, msgtype: str, layout: Any = None) -> Any:
        if topic not in self.connections:
            self.connections[topic] = self.writer.add_connection(topic, msgtype, typestore=self.store)
            self.counts[topic] = 0
            if layout is not None:
                self.layouts[topic] = layout()
        return self.connections[topic]

    def _write(self, topic: str, times_ns: np.ndarray, messages: Iterable[bytes]) -> None:
        connection = self.connections[topic]
        for ns, data in zip(times_ns.tolist(), messages, strict=True):
            self.writer.write(connection, ns, data)
            self.counts[topic] += 1

    def _packed(self, topic: str, msgtype: str, layout: Any, t_s: np.ndarray, values: dict[str, Any]) -> None:
        self._topic(topic, msgtype, layout)
        ns = stamps(t_s, self.origin_ns)
        messages = self.layouts[topic].pack(
            len(ns), {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000, **values}
        )
        self._write(topic, ns, messages)

    def add(self, results: dict[str, MethodResult]) -> None:
        """One chunk of results (the engine's ``on_chunk``): each method's odometry, sigma and
        error at its output epochs and its updates of every source; what the events need kept."""
        self.events.add(results)
        for method, r in results.items():
            self._estimates(f"/tauv/{method}", r)
            for source, record in r.updates.items():
                self._innovations(f"/tauv/{method}/innovations/{source}", record)

    def add_smoothed(self, results: dict[str, MethodResult]) -> None:
        """One chunk of smoothed results (the engine's ``on_smoothed_chunk``)."""
        for method, r in results.items():
            self._estimates(f"/tauv/{method}/smoothed", r)

    def _estimates(self, prefix: str, r: MethodResult) -> None:
        if not r.t_s.size:
            return
        i = self.run
        C_nb = None
        if r.est_euler_rad is not None:
            from tauvcore.geo.rotations import C_nb_from_euler

            C_nb = C_nb_from_euler(r.est_euler_rad[:, i])
        values = odometry_values(r.est_pos_n[:, i], None if r.est_vel_n is None else r.est_vel_n[:, i], C_nb)
        deg = np.pi / 180.0
        pos, vel = r.pos_sigma_m[:, i], r.vel_sigma_mps[:, i]
        tilt, heading = r.tilt_sigma_deg[:, i] * deg, r.heading_sigma_deg[:, i] * deg
        values["pose_covariance"] = _covariance(
            [pos, pos, pos, tilt, tilt, heading], [1 / 3] * 3 + [0.5, 0.5, 1]
        )
        if r.pos_cov_ne_m2 is not None:
            _horizontal_covariance(values["pose_covariance"], r.pos_cov_ne_m2[:, i], pos)
        values["twist_covariance"] = _covariance([vel, vel, vel], [1 / 3] * 3)
        self._packed(f"{prefix}/odometry", ODOMETRY, odometry_layout, r.t_s, values)
        for kind, topic in (("Sigma", "sigma"), ("Error", "error")):
            name = f"tauv_msgs/msg/{kind}"
            values = {field: getattr(r, field)[:, i] for field in scalar_fields(name)}
            self._packed(f"{prefix}/{topic}", name, lambda name=name: scalars_layout(name), r.t_s, values)

    def _innovations(self, topic: str, record: UpdateRecord) -> None:
        i = self.run
        rows = record.innovation.shape[2]
        beams = 0 if record.beams_available is None else record.beams_available.shape[2]
        values: dict[str, Any] = {
            name: getattr(record, name)[:, i]
            for name in ("z", "innovation", "innovation_var", "fused_rows", "rejected_rows", "test_ratio")
        }
        values.update(
            {
                name: getattr(record, name)[:, i]
                for name in ("nis", "nis_dof", "valid", "fused", "rejected", "unusable")
            }
        )
        if record.beams_available is not None:
            values["beams_available"] = record.beams_available[:, i]
        values["mode"] = -1 if record.mode is None else record.mode[:, i]
        values["reset"] = False if record.reset is None else record.reset[:, i]
        if record.t_s.size:
            self._packed(
                topic, "tauv_msgs/msg/Innovation", lambda: innovation_layout(rows, beams), record.t_s, values
            )

    def add_truth(self, truth: Any, k0: int) -> None:
        """The truth (or a log's reference) of one chunk of IMU samples from sample ``k0``
        (a tauvcore.truth.Truth): its rows at the output epochs (every ``step``-th sample), where
        known."""
        rows = np.arange((-k0) % self.step, truth.num_samples, self.step)
        known = rows[np.isfinite(truth.pos_n[rows]).all(axis=1)]
        if not known.size:
            return
        values = odometry_values(truth.pos_n[known], truth.vel_n[known], truth.C_nb[known])
        self._packed("/tauv/truth/odometry", ODOMETRY, odometry_layout, truth.t_s[known], values)

    def add_events(self, events: Iterable[Any]) -> None:
        """Events (tauvcore.eval.events.Event), each stamped at its start (the topic is made even
        without any: its absence would read as "not recorded")."""
        connection = self._topic("/tauv/events", "tauv_msgs/msg/Event")
        types = self.store.types
        for event in events:
            ns = int(stamps(np.array([event.start_s]), self.origin_ns)[0])
            stamp = types["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
            message = types["tauv_msgs/msg/Event"](
                header=types["std_msgs/msg/Header"](stamp=stamp, frame_id=""),
                kind=str(event.kind),
                start_s=float(event.start_s),
                end_s=float(event.end_s),
                method=str(event.method or ""),
                beams=np.asarray(list(event.beams or ()), dtype=np.uint8),
                text=str(event.text),
                source=str(getattr(event, "source", None) or ""),
            )
            self.writer.write(connection, ns, bytes(self.store.serialize_cdr(message, "tauv_msgs/msg/Event")))
            self.counts["/tauv/events"] += 1

    def finish(self) -> None:
        """Write the events, close the bag and move its ``.mcap`` over ``path`` (atomically: a
        rename in the same directory); the temporary directory goes whatever happens."""
        try:
            self.add_events(self.events.events())
            self.writer.close()
            data = self.bag / f"{self.bag.name}.mcap"
            os.chmod(data, new_file_mode(self.path))
            os.replace(data, self.path)
        finally:
            shutil.rmtree(self.spool, ignore_errors=True)

    def discard(self) -> None:
        """The run failed or was interrupted: the temporary directory goes, ``path`` untouched."""
        with contextlib.suppress(Exception):
            self.writer.close()
        shutil.rmtree(self.spool, ignore_errors=True)


EVENT_FIELDS = (
    *("rejected", "rejected_rows", "test_ratio", "valid", "reset", "beams_available"),
    *("rejected_in_bin", "reset_in_bin", "lost_in_bin"),
)
"""What tauvcore.eval.events reads of an update record, besides its times (the last three: a
record reduced to time bins, tauvcore.eval.envelope.DecimatedUpdates)."""


class StreamedEvents:
    """The events of run ``run`` (tauvcore.eval.events.run_events) from results handed in chunk by
    chunk: of each update only what the events are made of (its time, the gate's flags and test
    ratio, the DVL's beams and resets: a few tens of bytes an update, not the series), and at the
    end run_events of those, so the same events as of the whole results
    (tests/unit/app/test_mcap.py)."""

    def __init__(self, config: Config, run: int = 0) -> None:
        self.config = config
        self.run = run
        self.kept: dict[
            str, dict[str, dict[str, list[np.ndarray]]]
        ] = {}  # method -> record -> field -> chunks
        self.diverged_at_s: dict[str, np.ndarray] = {}  # each method's verdict so far, (1,)

    def add(self, results: dict[str, MethodResult]) -> None:
        """One chunk of results (the engine's ``on_chunk``)."""
        i = self.run
        for method, r in results.items():
            self.diverged_at_s[method] = r.diverged_at_s[i : i + 1]
            kept = self.kept.setdefault(method, {})
            for source, record in r.updates.items():
                fields = kept.setdefault(source, {})
                fields.setdefault("t_s", []).append(record.t_s)
                for name in EVENT_FIELDS:
                    value = getattr(record, name, None)
                    if value is not None:
                        fields.setdefault(name, []).append(value[:, i : i + 1])
            if r.vkf_trace is not None and "rpm_in_use" in r.vkf_trace:
                t_s = np.asarray(r.vkf_trace["t_s"])
                in_use = np.reshape(r.vkf_trace["rpm_in_use"], (t_s.size, -1))[:, i : i + 1]
                trace = kept.setdefault("vkf_trace", {})
                trace.setdefault("t_s", []).append(t_s)
                trace.setdefault("rpm_in_use", []).append(in_use)

    def events(self) -> list[Any]:
        """Every event of the run so far (run_events' list)."""
        from types import SimpleNamespace

        from tauvcore.eval.events import run_events

        slim: dict[str, Any] = {}  # what run_events reads of each method's results, run 0 alone
        for method, records in self.kept.items():
            joined = {
                source: {name: np.concatenate(parts) for name, parts in fields.items()}
                for source, fields in records.items()
            }
            trace = joined.pop("vkf_trace", None)
            updates = {
                source: SimpleNamespace(**{name: fields.get(name) for name in ("t_s", *EVENT_FIELDS)})
                for source, fields in joined.items()
            }
            slim[method] = SimpleNamespace(
                pos_err_m=np.zeros((0, 1)),
                diverged_at_s=self.diverged_at_s[method],
                updates=updates,
                vkf_trace=trace,
            )
        return run_events(slim, self.config, 0)


def simulated_truth(config: Config) -> Iterable[tuple[Any, int]]:
    """A simulation's truth chunk by chunk with each chunk's first sample (for
    :meth:`McapResults.add_truth`): the mission's, made again from its configuration (the truth
    draws nothing at random)."""
    from tauvcore.truth import truth_stream

    step = max(1, round(config.imu.rate_hz / config.filter.output_rate_hz))
    stream = truth_stream(config.trajectory, config.earth, config.imu.rate_hz, chunk_samples=step * 1000)
    for k0, chunk in stream:
        yield chunk, k0


def mcap_bytes(
    config: Config,
    results: dict[str, MethodResult],
    truth: Iterable[tuple[Any, int]] = (),
    origin_s: float = 0.0,
) -> bytes:
    """The MCAP file of finished results (the dashboard's download), run 0, as bytes: written in
    a temporary directory, read and removed."""
    with tempfile.TemporaryDirectory(prefix="tauv-mcap-") as directory:
        path = os.path.join(directory, "results.mcap")
        writer = McapResults(path, config, origin_s)
        try:
            for chunk, k0 in truth:
                writer.add_truth(chunk, k0)
            writer.add(results)
            smoothed = {m: r.smoothed for m, r in results.items() if r.smoothed is not None}
            if smoothed:
                writer.add_smoothed(smoothed)
        except BaseException:
            writer.discard()
            raise
        writer.finish()
        return Path(path).read_bytes()
