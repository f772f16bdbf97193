"""Hostile recorded logs for ``tauv replay``: a few base logs written from short seeded
simulations, and one generator per named class that breaks a copy of a base in one way.

A class states what the replay must do with its logs (:class:`Expect`): refuse them (exit 2, one
line naming the table's file and, for a bad cell, its column, its row and its value), accept them
(exit 0), or either. A generator takes a seeded ``numpy.random.Generator`` (through
:class:`Ctx`): the same cases on every run. The classes come in five families:

- structure: tables missing or doubled, columns missing, doubled or unknown, files that are empty,
  cut short, badly encoded, not regular files, or not Parquet;
- cells: a cell that is not a finite number (text, N/A, NaN, infinities, empty, 1e300, a huge
  integer), and the one place an empty cell is allowed (a DVL beam that did not return);
- time: clocks unsorted, repeated, with a hole, jittered, in milliseconds, or off the IMU's span;
- units and signs: the right column names over values in other units, signs or axes (gyro in
  deg/s, accelerometers in g or mg or upside down, ...), which only a plausibility check sees;
- benign: logs a reader must take as they are (the bases, columns reordered, padded cells,
  Parquet for CSV, a good ``log.toml``).
"""

from __future__ import annotations

import math
import os
import re
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tauvcore import units
from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.logs import TABLES
from tauvcore.logs.columns import DVL_BEAMS, DVL_BODY, IMU_INCREMENTS, IMU_RATES, REF_VEL
from tauvcore.logs.writer import simulation_tables, write_log

REFUSE, ACCEPT, EITHER = "refuse", "accept", "either"
G0 = 9.80665
"""Standard gravity [m/s^2]: an accelerometer 'in g' is the SI value divided by it."""
KNOT_MPS = 1852.0 / 3600.0
AIDING = ("dvl", "depth", "attitude", "reference")
"""The tables beside the IMU, each on the IMU's clock."""


# ------------------------------------------------------------------------------------ expectations
@dataclass(frozen=True)
class Expect:
    """What ``tauv replay`` must do with one hostile log.

    names: on exit 2, for each group one of its strings must be in the message (the file; the
    column; the value, written in one of several ways).
    rows: on exit 2, the message must say ``row N`` for one of these (data rows from 1).
    note: on exit 0, a ``tauv: note:`` line must name this (a resampled IMU says so).
    """

    outcome: str
    names: tuple[tuple[str, ...], ...] = ()
    rows: tuple[int, ...] = ()
    note: str | None = None


def refuse(*groups: tuple[str, ...] | str, rows: tuple[int, ...] = ()) -> Expect:
    return Expect(REFUSE, tuple((g,) if isinstance(g, str) else tuple(g) for g in groups), rows)


def accept(note: str | None = None) -> Expect:
    return Expect(ACCEPT, note=note)


def either(*groups: tuple[str, ...] | str) -> Expect:
    return Expect(EITHER, tuple((g,) if isinstance(g, str) else tuple(g) for g in groups))


class Token(str):
    """A number a message must hold whole, not inside another number ('10' is not in 'row 104',
    '5' not in '0.5' or '-5')."""

    def found_in(self, text: str) -> bool:
        return re.search(rf"(?<![\w.+-]){re.escape(self)}(?!\w|\.\d)", text) is not None


def mentions(text: str, name: str) -> bool:
    """Whether ``text`` holds ``name`` (a :class:`Token` whole)."""
    return name.found_in(text) if isinstance(name, Token) else name in text


def number_texts(x: float) -> tuple[str, ...]:
    """Ways a message may write the number ``x``."""
    texts = {repr(x), f"{x:.6g}", f"{x:g}", str(x)}
    if math.isfinite(x) and x == int(x) and abs(x) < 1e15:
        texts.add(str(int(x)))
    return tuple(Token(t) for t in sorted(texts))


def cell_texts(text: str) -> tuple[str, ...]:
    """Ways a message may quote the cell ``text`` (itself; the number it reads as)."""
    if text == "":
        return ("empty", "''")
    out = {text, repr(text)}
    try:
        x = float(text)
    except ValueError:
        return tuple(sorted(out))
    if math.isfinite(x):
        out.update(number_texts(x))
    elif text.isdigit():       # a huge integer: its first digits are enough
        out.add(text[:12])
    return tuple(sorted(out))


# ------------------------------------------------------------------------------------------- bases
@dataclass(frozen=True)
class Base:
    """A valid log on disk, and the columns it was written from (table -> column -> values)."""

    name: str
    directory: Path
    fmt: str  # csv | parquet
    tables: dict[str, dict[str, np.ndarray]]
    flags: tuple[str, ...] = ()  # what its replay needs (a local reference: --earth flat)

    @property
    def imu(self) -> str:
        return "rates" if "gyro_x_rps" in self.tables["imu"] else "increments"

    @property
    def dvl(self) -> str:
        return "beams" if "beam1_mps" in self.tables["dvl"] else "body"

    @property
    def reference(self) -> str | None:
        ref = self.tables.get("reference")
        if ref is None:
            return None
        return "local" if "north_m" in ref else ("deg" if "lat_deg" in ref else "rad")

    def file(self, table: str) -> str:
        return f"{table}.{self.fmt}"

    def gyro(self) -> tuple[str, ...]:
        return IMU_RATES[:3] if self.imu == "rates" else IMU_INCREMENTS[:3]

    def accel(self) -> tuple[str, ...]:
        return IMU_RATES[3:] if self.imu == "rates" else IMU_INCREMENTS[3:]

    def dvl_velocity(self) -> tuple[str, ...]:
        return DVL_BEAMS if self.dvl == "beams" else DVL_BODY

    def ref_depth(self) -> str:
        return "down_m" if self.reference == "local" else "depth_m"


def _simulation(trajectory: str, model: str, duration_s: float, seed: int):
    config = (Config().replace("trajectory", name=trajectory, duration_s=duration_s).replace("earth", model=model)
              .replace("imu", rate_hz=100.0).replace("run", aiding=("dvl", "depth", "mag")))
    return simulate(config, np.random.default_rng(seed))


def _as_rates(imu: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Increments over each interval as the rates at its end (row 0: row 1's)."""
    t = imu["t_s"]
    dt = np.diff(t)
    out = {"t_s": t}
    for inc, rate in zip(("dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_mps", "dv_y_mps", "dv_z_mps"),
                         IMU_RATES, strict=True):
        r = np.empty_like(t)
        r[1:] = imu[inc][1:] / dt
        r[0] = r[1]
        out[rate] = r
    return out


def _body_dvl(sim, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """The DVL as a body velocity (truth plus 1 cm/s noise), one ping in ten flagged invalid."""
    k = sim.dvl.index
    vel = sim.truth.vel_b[k] + rng.normal(0.0, 0.01, (k.size, 3))
    valid = (rng.random(k.size) > 0.1).astype(float)
    out = {"t_s": sim.truth.t_s[k]}
    out.update({n: vel[:, i] for i, n in enumerate(DVL_BODY)})
    out["valid"] = valid
    return out


def _in_degrees(table: dict[str, np.ndarray], every: int) -> dict[str, np.ndarray]:
    """A table's angles (``*_rad``: latitude, longitude, attitude) in degrees, every ``every``-th row."""
    out = {}
    for name, values in table.items():
        values = values[::every]
        if name.endswith("_rad"):
            out[name[:-4] + "_deg"] = np.degrees(values)
        else:
            out[name] = values
    return out


def build_bases(root: Path) -> list[Base]:
    """The base logs under ``root``: CSV and Parquet; with and without a reference (geodetic in
    radians at the IMU rate, in degrees at 10 Hz, local NED on a flat earth); DVL beams or body
    velocity; IMU increments or rates. Three seeded simulations of 20-30 s at 100 Hz, all figure
    eights: the vehicle turns from the start, so a gyro or attitude in the wrong unit, sign or
    axis shows against the reference or the attitude sensor (a straight leg would hide it)."""
    rng = np.random.default_rng(20240601)
    figure8 = simulation_tables([SimChunk.whole(_simulation("figure8", "wgs84", 20.0, 1))])
    second_sim = _simulation("figure8", "wgs84", 30.0, 2)
    second = simulation_tables([SimChunk.whole(second_sim)])
    second["imu"] = _as_rates(second["imu"])
    second["dvl"] = _body_dvl(second_sim, rng)
    second["reference"] = _in_degrees(second["reference"], 10)
    second["attitude"] = _in_degrees(second["attitude"], 1)
    flat = simulation_tables([SimChunk.whole(_simulation("figure8", "flat", 20.0, 3))])

    def without_reference(tables: dict) -> dict:
        return {t: cols for t, cols in tables.items() if t != "reference"}

    specs = [
        ("csv-increments-beams-ref_rad", "csv", figure8, ()),
        ("parquet-increments-beams-ref_rad", "parquet", figure8, ()),
        ("csv-rates-body-ref_deg_10hz", "csv", second, ()),
        ("csv-increments-beams-noref", "csv", without_reference(figure8), ()),
        ("parquet-rates-body-noref", "parquet", without_reference(second), ()),
        ("csv-flat-local_ref", "csv", flat, ("--earth", "flat")),
    ]
    bases = []
    for name, fmt, tables, flags in specs:
        directory = root / name
        write_log(directory, tables, fmt)
        bases.append(Base(name, directory, fmt, tables, flags))
    return bases


# --------------------------------------------------------------------------------- the case at hand
class Ctx:
    """One case being made: a copy of ``base`` in ``directory``, the seeded generator, and the
    edits a class makes to it (columns through the log writer, bytes and special files by hand)."""

    def __init__(self, rng: np.random.Generator, base: Base, directory: Path) -> None:
        self.rng, self.base, self.dir = rng, base, directory

    # --- choices
    def choice(self, items):
        items = list(items)
        return items[int(self.rng.integers(len(items)))]

    def tables(self) -> list[str]:
        return [t for t in TABLES if t in self.base.tables]

    def aiding(self) -> list[str]:
        return [t for t in AIDING if t in self.base.tables]

    def rows(self, table: str) -> int:
        return int(self.base.tables[table]["t_s"].size)

    def row(self, table: str, first: int = 1) -> int:
        """A data row (from 1) of ``table``, at least ``first``."""
        return int(self.rng.integers(first, self.rows(table) + 1))

    def required_cell(self) -> tuple[str, str, int]:
        """A cell the reader must read as a finite number: any column but a DVL beam (empty there
        is a beam that did not return) and ``valid``; not in the IMU's first row (its increments
        are not used)."""
        table = self.choice(["imu", "imu"] + self.aiding())
        columns = [c for c in self.base.tables[table] if c not in DVL_BEAMS and c != "valid"]
        column = self.choice(columns)
        return table, column, self.row(table, first=2 if table == "imu" else 1)

    def path(self, table: str, fmt: str | None = None) -> Path:
        return self.dir / f"{table}.{fmt or self.base.fmt}"

    def columns(self, table: str) -> dict[str, np.ndarray]:
        return {n: v.copy() for n, v in self.base.tables[table].items()}

    # --- edits
    def write(self, table: str, columns: dict[str, np.ndarray], fmt: str | None = None) -> None:
        """Replace ``table`` by ``columns`` (in ``fmt``, the base's by default)."""
        for ext in ("csv", "parquet"):
            self.path(table, ext).unlink(missing_ok=True)
        write_log(self.dir, {table: columns}, fmt or self.base.fmt)

    def remove(self, table: str) -> None:
        self.path(table).unlink()

    def read_bytes(self, table: str) -> bytes:
        return self.path(table).read_bytes()

    def write_bytes(self, table: str, data: bytes) -> None:
        self.path(table).write_bytes(data)

    def lines(self, table: str) -> list[str]:
        """The CSV table's lines (header first), without their newlines."""
        return self.path(table).read_text().splitlines()

    def write_lines(self, table: str, lines: list[str], newline: str = "\n") -> None:
        self.write_bytes(table, (newline.join(lines) + newline).encode())

    def set_cell(self, table: str, column: str, row: int, text: str,
                 number: float | None = None) -> tuple[tuple[int, ...], tuple[str, ...]]:
        """Cell (row from 1) of ``column`` written as ``text`` in CSV. In Parquet: ``number`` in
        the float column if given, a null for '', else the column as text (other cells their
        repr) with ``text`` in that row.

        Returns the rows a refusal may name and the ways it may quote the value: the cell's; for
        a Parquet column turned to text also its first row, where a reader that wants numbers
        stored as numbers finds the column's type wrong."""
        shown = ((row,), cell_texts(text))
        if self.base.fmt == "csv":
            lines = self.lines(table)
            index = lines[0].split(",").index(column)
            fields = lines[row].split(",")
            fields[index] = f'"{text}"' if ("," in text or '"' in text) else text
            lines[row] = ",".join(fields)
            self.write_lines(table, lines)
            return shown
        import pyarrow as pa
        import pyarrow.parquet as pq

        cols = self.columns(table)
        arrays = {}
        for name, values in cols.items():
            if name != column:
                arrays[name] = pa.array(values)
            elif number is not None or text == "":
                v = values.astype(object)
                v[row - 1] = number
                arrays[name] = pa.array(list(v), type=pa.float64())
            else:
                v = ["" if np.isnan(x) else repr(float(x)) for x in values]
                v[row - 1] = text
                arrays[name] = pa.array(v, type=pa.string())
                shown = ((row, 1), shown[1] + cell_texts(v[0]))
        self.path(table).unlink()
        pq.write_table(pa.table(arrays), self.path(table))
        return shown


@dataclass(frozen=True)
class HostileClass:
    """A named kind of hostile log: its family, what the replay must do, the bases it applies to,
    and the generator that makes one case (returns the mutation, in words, and the expectation)."""

    name: str
    family: str
    outcome: str
    make: Callable[[Ctx], tuple[str, Expect]]
    fits: Callable[[Base], bool] = field(default=lambda base: True)
    weight: int = 1  # cases per unit of the tier's size (more for classes with many variants)


CLASSES: list[HostileClass] = []


def hostile(name: str, family: str, outcome: str, fits: Callable[[Base], bool] | None = None, weight: int = 1):
    def register(make: Callable[[Ctx], tuple[str, Expect]]) -> Callable[[Ctx], tuple[str, Expect]]:
        CLASSES.append(HostileClass(name, family, outcome, make, fits or (lambda base: True), weight))
        return make
    return register


def is_csv(base: Base) -> bool:
    return base.fmt == "csv"


def first_bad_time(t: np.ndarray) -> tuple[int, float]:
    """The first row (from 1) whose time does not increase, and that time."""
    k = int(np.argmax(np.diff(t) <= 0)) + 1
    return k + 1, float(t[k])


def take_rows(columns: dict[str, np.ndarray], index: np.ndarray) -> dict[str, np.ndarray]:
    return {n: v[index] for n, v in columns.items()}


def angle_stems(column: str) -> tuple[str, ...]:
    """A column and, for an angle, the names its stem goes by (a message may name either unit)."""
    for suffix in ("_rad", "_deg"):
        if column.endswith(suffix):
            stem = column[: -len(suffix)]
            return (column, stem + "_rad", stem + "_deg")
    return (column,)


# ======================================================================================= structure
@hostile("missing table", "structure", REFUSE)
def _missing_table(c: Ctx) -> tuple[str, Expect]:
    if c.choice(["imu", "start"]) == "imu":
        c.remove("imu")
        return "imu table deleted", refuse(("imu.csv", "imu.parquet"))
    for table in ("reference", "attitude"):
        if table in c.base.tables:
            c.remove(table)
    return "reference and attitude tables deleted (nothing to start from)", refuse(
        ("reference.csv", "attitude.csv", "reference.parquet", "attitude.parquet"))


@hostile("missing column", "structure", REFUSE, weight=2)
def _missing_column(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    # (not an optional one: the DVL's valid flag, a simulated log's true errors)
    column = c.choice([n for n in c.base.tables[table] if n != "valid" and not n.startswith("true_")])
    cols = c.columns(table)
    del cols[column]
    c.write(table, cols)
    return f"column {column!r} of {table} deleted", refuse(c.base.file(table), angle_stems(column))


@hostile("duplicated column", "structure", REFUSE)
def _duplicated_column(c: Ctx) -> tuple[str, Expect]:
    """A second column under the name of one the reader uses (its values equal or not): which
    of the two is meant cannot be known."""
    table = c.choice(c.tables())
    cols = c.columns(table)
    column = c.choice(list(cols))
    copy = cols[column] if c.choice([True, False]) else cols[column] + 1.0
    position = int(c.rng.integers(0, len(cols) + 1))
    names, arrays = list(cols), list(cols.values())
    names.insert(position, column)
    arrays.insert(position, copy)
    if c.base.fmt == "csv":
        rows = np.column_stack(arrays)
        c.write_lines(table, [",".join(names)] + [",".join("" if np.isnan(v) else repr(float(v)) for v in row)
                                                  for row in rows])
    else:
        import pyarrow as pa
        import pyarrow.parquet as pq

        c.remove(table)
        pq.write_table(pa.Table.from_arrays([pa.array(v) for v in arrays], names=names), c.path(table))
    same = "the same values" if copy is cols[column] else "other values"
    return f"{table}: a second column {column!r} ({same}) at position {position}", refuse(c.base.file(table), column)


@hostile("unknown column", "structure", ACCEPT)
def _unknown_column(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    cols = c.columns(table)
    name = c.choice(["temperature_c", "sound_speed_mps", "status", "heading_mag_deg"])
    n = c.rows(table)
    position = int(c.rng.integers(0, len(cols) + 1))
    items = list(cols.items())
    items.insert(position, (name, np.round(c.rng.normal(10.0, 3.0, n), 3)))
    c.write(table, dict(items))
    return f"{table}: an extra numeric column {name!r} at position {position}", accept()


@hostile("empty file", "structure", REFUSE)
def _empty_file(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    c.write_bytes(table, b"")
    return f"{table} file of 0 bytes", refuse(c.base.file(table))


@hostile("header only", "structure", REFUSE)
def _header_only(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    cols = c.columns(table)
    c.write(table, {n: v[:0] for n, v in cols.items()})
    return f"{table}: the header, no rows", refuse(c.base.file(table))


@hostile("short row", "structure", REFUSE, fits=is_csv)
def _short_row(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    row = c.row(table)
    lines = c.lines(table)
    lines[row] = lines[row].rsplit(",", 1)[0]
    c.write_lines(table, lines)
    return f"{table}: row {row} one field short", refuse(c.base.file(table), rows=(row,))


@hostile("long row", "structure", REFUSE, fits=is_csv)
def _long_row(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    row = c.row(table)
    lines = c.lines(table)
    lines[row] += c.choice([",1.0", ",", ",0,0"])
    c.write_lines(table, lines)
    return f"{table}: row {row} with an extra field", refuse(c.base.file(table), rows=(row,))


@hostile("byte order mark", "structure", EITHER, fits=is_csv)
def _bom(c: Ctx) -> tuple[str, Expect]:
    """A UTF-8 BOM (as spreadsheets write): read past, or refused naming the file."""
    table = c.choice(c.tables())
    c.write_bytes(table, b"\xef\xbb\xbf" + c.read_bytes(table))
    return f"{table}: UTF-8 byte order mark at the start", either(c.base.file(table))


@hostile("crlf line endings", "structure", ACCEPT, fits=is_csv)
def _crlf(c: Ctx) -> tuple[str, Expect]:
    tables = c.tables() if c.choice([True, False]) else [c.choice(c.tables())]
    for table in tables:
        c.write_lines(table, c.lines(table), newline="\r\n")
    return f"CRLF line endings in {', '.join(tables)}", accept()


@hostile("latin-1 byte in header", "structure", REFUSE, fits=is_csv)
def _latin1_header(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    data = c.read_bytes(table)
    header, rest = data.split(b"\n", 1)
    if c.choice(["extra", "rename"]) == "extra":   # an unknown column, named with a degree sign
        lines = [line + b",1.0" for line in rest.rstrip(b"\n").split(b"\n")]
        data = header + b",temp_\xb0c\n" + b"\n".join(lines) + b"\n"
        how = "an extra column 'temp_\\xb0c' (Latin-1 degree sign)"
    else:
        data = header.replace(b"t_s", b"t_\xb5s", 1) + b"\n" + rest
        how = "'t_s' written 't_\\xb5s' (Latin-1 micro sign)"
    c.write_bytes(table, data)
    return f"{table}: header with {how}", refuse(c.base.file(table))


@hostile("latin-1 byte in a cell", "structure", REFUSE, fits=is_csv)
def _latin1_cell(c: Ctx) -> tuple[str, Expect]:
    table, column, row = c.required_cell()
    lines = c.lines(table)
    index = lines[0].split(",").index(column)
    fields = lines[row].split(",")
    fields[index] = fields[index][:4] + "\udce9"          # the byte 0xE9 (é in Latin-1)
    lines[row] = ",".join(fields)
    c.write_bytes(table, ("\n".join(lines) + "\n").encode("utf-8", "surrogateescape"))
    return f"{table}: column {column!r}, row {row}: a Latin-1 byte 0xE9 in the number", refuse(
        c.base.file(table), column, rows=(row,))


@hostile("nul byte", "structure", REFUSE, fits=is_csv)
def _nul(c: Ctx) -> tuple[str, Expect]:
    table, column, row = c.required_cell()
    lines = c.lines(table)
    index = lines[0].split(",").index(column)
    fields = lines[row].split(",")
    at = int(c.rng.integers(0, len(fields[index]) + 1))
    fields[index] = fields[index][:at] + "\x00" + fields[index][at:]
    lines[row] = ",".join(fields)
    c.write_lines(table, lines)
    return f"{table}: column {column!r}, row {row}: a NUL byte at character {at}", refuse(
        c.base.file(table), column, rows=(row,))


@hostile("directory as table", "structure", REFUSE)
def _directory(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    c.remove(table)
    c.path(table).mkdir()
    if c.choice([True, False]):
        (c.path(table) / "part-0.csv").write_text("t_s\n0.0\n")
    return f"{table}: a directory in place of the file", refuse(c.base.file(table))


@hostile("symlink loop as table", "structure", REFUSE)
def _symlink_loop(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    c.remove(table)
    os.symlink(c.path(table).name, c.path(table))
    return f"{table}: a symbolic link to itself", refuse(c.base.file(table))


@hostile("dangling symlink as table", "structure", REFUSE)
def _dangling(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    c.remove(table)
    os.symlink(f"moved-{c.path(table).name}", c.path(table))
    return f"{table}: a symbolic link to a file that does not exist", refuse(c.base.file(table))


@hostile("fifo as table", "structure", REFUSE)
def _fifo(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    c.remove(table)
    os.mkfifo(c.path(table))
    return f"{table}: a FIFO in place of the file (reading it would block)", refuse(c.base.file(table))


@hostile("both csv and parquet", "structure", REFUSE)
def _both(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    other = "parquet" if c.base.fmt == "csv" else "csv"
    write_log(c.dir, {table: c.columns(table)}, other)
    return f"{table}: both {table}.csv and {table}.parquet", refuse(f"{table}.csv", f"{table}.parquet")


@hostile("corrupt parquet", "structure", REFUSE)
def _corrupt_parquet(c: Ctx) -> tuple[str, Expect]:
    """Parquet that cannot be read: cut short (footer lost), its footer length or magic broken,
    CSV or random bytes under the name. A CSV base gets one table as such a Parquet file."""
    table = c.choice(c.tables())
    if c.base.fmt == "csv":
        c.remove(table)
        write_log(c.dir, {table: c.columns(table)}, "parquet")
    path = c.dir / f"{table}.parquet"
    data = path.read_bytes()
    how = c.choice(["truncated", "footer length", "magic", "csv text", "random bytes"])
    if how == "truncated":
        data = data[: int(c.rng.integers(0, len(data) - 8))]
    elif how == "footer length":
        data = data[:-8] + (0x7FFFFFF0).to_bytes(4, "little") + b"PAR1"
    elif how == "magic":
        data = b"PAR0" + data[4:-4] + b"PAR0"
    elif how == "csv text":
        data = b"t_s,depth_m\n0.0,1.0\n1.0,2.0\n"
    else:
        data = b"PAR1" + c.rng.bytes(int(c.rng.integers(8, 5000))) + b"PAR1"
    path.write_bytes(data)
    return f"{table}.parquet {how}", refuse(f"{table}.parquet")


@hostile("parquet bytes flipped", "structure", EITHER)
def _parquet_flips(c: Ctx) -> tuple[str, Expect]:
    """A few bytes inside a Parquet file changed: the file may still read (a changed value) or
    not; either way an answer, not a crash."""
    table = c.choice(c.tables())
    if c.base.fmt == "csv":
        c.remove(table)
        write_log(c.dir, {table: c.columns(table)}, "parquet")
    path = c.dir / f"{table}.parquet"
    data = bytearray(path.read_bytes())
    where = c.rng.integers(4, len(data) - 4, size=int(c.rng.integers(1, 6)))
    for i in where:
        data[i] = int(c.rng.integers(0, 256))
    path.write_bytes(bytes(data))
    return f"{table}.parquet with bytes {sorted(int(i) for i in where)} changed", either(f"{table}.parquet")


@hostile("truncated csv", "structure", REFUSE, fits=is_csv)
def _truncated(c: Ctx) -> tuple[str, Expect]:
    """The writer stopped mid-number: the last line cut inside a field that is not its last."""
    table = c.choice(c.tables())
    data = c.read_bytes(table).rstrip(b"\n")
    start = data.rfind(b"\n") + 1
    last = data[start:]
    commas = [i for i, ch in enumerate(last) if ch == ord(",")]
    field_end = c.choice(commas)
    field_start = max([i + 1 for i in commas if i < field_end], default=0)
    cut = int(c.rng.integers(field_start + 1, field_end)) if field_end > field_start + 1 else field_end
    c.write_bytes(table, data[: start + cut])
    row = data.count(b"\n")
    return f"{table}: file ends at byte {start + cut}, inside a number of its last row ({row})", refuse(
        c.base.file(table), rows=(row,))


@hostile("broken log.toml", "structure", REFUSE)
def _broken_log_config(c: Ctx) -> tuple[str, Expect]:
    text = c.choice([b"[dvl\nnoise_mps = 0.04\n", b"[dvl]\nnoise_mps = -1.0\n", b"[dvl]\nnoise_mp = 0.04\n",
                     b"[dvl]\nbeams = [7]\n", b"[dvl]\nnoise_mps = \"\xe9\"\n", b"\xff\xfe[\x00d\x00"])
    (c.dir / "log.toml").write_bytes(text)
    return f"log.toml in the log: {text!r}", refuse("log.toml")


# =========================================================================================== cells
def _cell_case(c: Ctx, texts: list[str]) -> tuple[str, Expect]:
    table, column, row = c.required_cell()
    text = c.choice(texts)
    rows, shown = c.set_cell(table, column, row, text)
    return f"{table}: column {column!r}, row {row}: {text!r}", refuse(
        c.base.file(table), column, shown, rows=rows)


@hostile("non-numeric cell", "cells", REFUSE, weight=2)
def _non_numeric(c: Ctx) -> tuple[str, Expect]:
    return _cell_case(c, ["abc", "1,5", "0x10", "1e", "--1", "1.2.3", "12abc", "one", "1_000", "TRUE"])


@hostile("N/A cell", "cells", REFUSE)
def _na(c: Ctx) -> tuple[str, Expect]:
    return _cell_case(c, ["N/A", "NA", "n/a", "null", "#N/A", "NULL"])


def _case_insensitive(c: Ctx, texts: list[str], shown: tuple[str, ...]) -> tuple[str, Expect]:
    table, column, row = c.required_cell()
    text = c.choice(texts)
    c.set_cell(table, column, row, text, float(text))
    return f"{table}: column {column!r}, row {row}: {text!r}", refuse(
        c.base.file(table), column, shown + (text,), rows=(row,))


@hostile("nan cell", "cells", REFUSE)
def _nan(c: Ctx) -> tuple[str, Expect]:
    return _case_insensitive(c, ["nan", "NaN", "NAN", "-nan"], ("nan", "NaN", "NAN"))


@hostile("inf cell", "cells", REFUSE)
def _inf(c: Ctx) -> tuple[str, Expect]:
    return _case_insensitive(c, ["inf", "Infinity", "+inf", "INF"], ("inf", "Inf", "INF"))


@hostile("-inf cell", "cells", REFUSE)
def _neg_inf(c: Ctx) -> tuple[str, Expect]:
    return _case_insensitive(c, ["-inf", "-Infinity", "-INF"], ("-inf", "-Inf", "-INF"))


@hostile("empty required cell", "cells", REFUSE)
def _empty(c: Ctx) -> tuple[str, Expect]:
    return _cell_case(c, [""])


@hostile("empty dvl beam", "cells", ACCEPT, fits=lambda b: b.dvl == "beams")
def _empty_beam(c: Ctx) -> tuple[str, Expect]:
    """Empty or NaN in a beam column: that beam did not return on that ping."""
    n = int(c.rng.integers(1, 6))
    done = []
    for _ in range(n):
        column, row, text = c.choice(DVL_BEAMS), c.row("dvl"), c.choice(["", "nan"])
        c.set_cell("dvl", column, row, text, float("nan") if text else None)
        done.append(f"{column} row {row} {text!r}")
    return "dvl: " + ", ".join(done), accept()


def _huge_case(c: Ctx, table: str, columns: tuple[str, ...], first: int = 1) -> tuple[str, Expect]:
    column = c.choice(columns)
    row = c.row(table, first)
    text = c.choice(["1e300", "-1e300", "1e200", "1.7976931348623157e308"])
    c.set_cell(table, column, row, text, float(text))
    return f"{table}: column {column!r}, row {row}: {text}", refuse(
        c.base.file(table), column, cell_texts(text), rows=(row,))


@hostile("1e300 in the imu", "cells", REFUSE)
def _huge_imu(c: Ctx) -> tuple[str, Expect]:
    return _huge_case(c, "imu", c.base.gyro() + c.base.accel(), first=2)


@hostile("1e300 depth", "cells", REFUSE)
def _huge_depth(c: Ctx) -> tuple[str, Expect]:
    choices = [("depth", "depth_m")] + ([("reference", c.base.ref_depth())] if c.base.reference else [])
    table, column = c.choice(choices)
    return _huge_case(c, table, (column,))


@hostile("1e300 dvl velocity", "cells", REFUSE)
def _huge_beam(c: Ctx) -> tuple[str, Expect]:
    return _huge_case(c, "dvl", c.base.dvl_velocity())


@hostile("huge integer cell", "cells", REFUSE)
def _huge_integer(c: Ctx) -> tuple[str, Expect]:
    """20 to 400 digits (beyond 309 not even a float). In ``t_s`` a finite one may be named by
    the row after it, whose time then goes back from it (the message quoting it)."""
    digits = int(c.choice([20, 25, 40, 309, 400]))
    text = str(int(c.rng.integers(1, 10))) + "".join(str(d) for d in c.rng.integers(0, 10, digits - 1))
    table, column, row = c.required_cell()
    rows, shown = c.set_cell(table, column, row, text)
    if column == "t_s" and math.isfinite(float(text)) and row < c.rows(table):
        rows += (row + 1,)
    return f"{table}: column {column!r}, row {row}: {text[:24]}... ({digits} digits)", refuse(
        c.base.file(table), column, shown, rows=rows)


# ============================================================================================ time
@hostile("unsorted times", "time", REFUSE)
def _unsorted(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    n = c.rows(table)
    i = int(c.rng.integers(0, n - 1))
    j = int(c.rng.integers(i + 1, min(n, i + 5)))
    order = np.arange(n)
    order[i], order[j] = j, i
    cols = take_rows(c.columns(table), order)
    c.write(table, cols)
    row, value = first_bad_time(cols["t_s"])
    return f"{table}: rows {i + 1} and {j + 1} swapped", refuse(
        c.base.file(table), "t_s", number_texts(value), rows=(row,))


@hostile("repeated times", "time", REFUSE)
def _repeated(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    n = c.rows(table)
    i = int(c.rng.integers(0, n - 1))
    cols = c.columns(table)
    if c.choice(["row", "time"]) == "row":
        cols = take_rows(cols, np.insert(np.arange(n), i + 1, i))
        how = f"row {i + 1} written twice"
    else:
        cols["t_s"][i + 1] = cols["t_s"][i]
        how = f"row {i + 2} with the time of row {i + 1}"
    c.write(table, cols)
    row, value = first_bad_time(cols["t_s"])
    return f"{table}: {how}", refuse(c.base.file(table), "t_s", number_texts(value), rows=(row,))


@hostile("imu gap over 50 intervals", "time", REFUSE)
def _gap(c: Ctx) -> tuple[str, Expect]:
    n = c.rows("imu")
    m = int(c.rng.integers(55, 400))
    i = int(c.rng.integers(n // 4, n // 2))
    cols = take_rows(c.columns("imu"), np.r_[0:i, i + m:n])
    c.write("imu", cols)
    return f"imu: rows {i + 1}-{i + m} deleted ({m + 1} intervals)", refuse(
        c.base.file("imu"), "t_s", number_texts(float(cols["t_s"][i])), rows=(i + 1,))


@hostile("imu jitter", "time", ACCEPT)
def _jitter(c: Ctx) -> tuple[str, Expect]:
    cols = c.columns("imu")
    t = cols["t_s"]
    dt = float(np.median(np.diff(t)))
    a = float(c.rng.uniform(0.03, 0.3))
    cols["t_s"] = t + c.rng.uniform(-a, a, t.size) * dt
    c.write("imu", cols)
    return f"imu: times jittered by up to {a:.0%} of the interval", accept(note=c.base.file("imu"))


@hostile("imu short hole", "time", ACCEPT)
def _short_hole(c: Ctx) -> tuple[str, Expect]:
    n = c.rows("imu")
    m = int(c.rng.integers(1, 45))
    i = int(c.rng.integers(n // 4, 3 * n // 4))
    c.write("imu", take_rows(c.columns("imu"), np.r_[0:i, i + m:n]))
    return f"imu: rows {i + 1}-{i + m} deleted ({m + 1} intervals)", accept(note=c.base.file("imu"))


@hostile("aiding time in ms", "time", REFUSE)
def _aiding_ms(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.aiding())
    cols = c.columns(table)
    cols["t_s"] = cols["t_s"] * 1000.0
    c.write(table, cols)
    return f"{table}: t_s in milliseconds", refuse(c.base.file(table), "t_s")


@hostile("imu time in ms or us", "time", REFUSE)
def _imu_ms(c: Ctx) -> tuple[str, Expect]:
    scale = c.choice([1e3, 1e6])
    cols = c.columns("imu")
    cols["t_s"] = cols["t_s"] * scale
    c.write("imu", cols)
    return f"imu: t_s in {'milliseconds' if scale == 1e3 else 'microseconds'}", refuse(c.base.file("imu"), "t_s")


@hostile("whole log in ms", "time", REFUSE)
def _all_ms(c: Ctx) -> tuple[str, Expect]:
    for table in c.tables():
        cols = c.columns(table)
        cols["t_s"] = cols["t_s"] * 1000.0
        c.write(table, cols)
    return "every table's t_s in milliseconds", refuse(tuple(c.base.file(t) for t in c.tables()), "t_s")


@hostile("times outside the imu span", "time", REFUSE)
def _outside(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.aiding())
    cols = c.columns(table)
    span = float(c.base.tables["imu"]["t_s"][-1])
    shift = (span + float(c.rng.uniform(5.0, 5000.0))) * c.choice([1.0, -1.0])
    cols["t_s"] = cols["t_s"] + shift
    c.write(table, cols)
    return f"{table}: t_s shifted by {shift:+.1f} s, off the IMU's span", refuse(c.base.file(table), "t_s")


# ================================================================================= units and signs
def _scale(c: Ctx, table: str, columns: tuple[str, ...], factor: float, what: str) -> tuple[str, Expect]:
    cols = c.columns(table)
    for n in columns:
        cols[n] = cols[n] * factor
    c.write(table, cols)
    return f"{table}: {', '.join(columns)} {what}", refuse(c.base.file(table), columns)


@hostile("gyro in deg/s", "units and signs", REFUSE)
def _gyro_deg(c: Ctx) -> tuple[str, Expect]:
    what = "in deg/s under _rps" if c.base.imu == "rates" else "in degrees under _rad"
    return _scale(c, "imu", c.base.gyro(), 1.0 / units.DEG, what)


@hostile("accelerometer in g", "units and signs", REFUSE)
def _accel_g(c: Ctx) -> tuple[str, Expect]:
    return _scale(c, "imu", c.base.accel(), 1.0 / G0, "in g")


@hostile("accelerometer in mg", "units and signs", REFUSE)
def _accel_mg(c: Ctx) -> tuple[str, Expect]:
    return _scale(c, "imu", c.base.accel(), 1000.0 / G0, "in mg")


@hostile("accelerometer sign flipped", "units and signs", REFUSE)
def _accel_sign(c: Ctx) -> tuple[str, Expect]:
    columns = c.base.accel() if c.choice([True, False]) else c.base.accel()[2:]
    return _scale(c, "imu", columns, -1.0, "negated")


@hostile("imu axes swapped", "units and signs", REFUSE)
def _axes_swapped(c: Ctx) -> tuple[str, Expect]:
    """Two axes swapped, one of them z (gravity and the turn rate on the wrong axis: an axis
    mix-up between x and y alone would look like a vehicle sailing sideways, which only a
    velocity comparison sees), for the accelerometers or for both triads."""
    a, b = c.choice([(0, 2), (1, 2)])
    triads = [c.base.accel()] + ([c.base.gyro()] if c.choice([True, False]) else [])
    cols = c.columns("imu")
    swapped = []
    for triad in triads:
        cols[triad[a]], cols[triad[b]] = cols[triad[b]].copy(), cols[triad[a]].copy()
        swapped += [triad[a], triad[b]]
    c.write("imu", cols)
    return f"imu: {' and '.join(f'{x}<->{y}' for x, y in zip(swapped[::2], swapped[1::2], strict=True))}", refuse(
        c.base.file("imu"), tuple(swapped))


@hostile("attitude in degrees under _rad", "units and signs", REFUSE)
def _attitude_deg(c: Ctx) -> tuple[str, Expect]:
    table = c.choice([t for t in ("attitude", "reference") if t in c.base.tables])
    cols = c.columns(table)
    renamed = {}
    for name, values in cols.items():
        stem = name.rsplit("_", 1)[0]
        if stem in ("roll", "pitch", "yaw"):
            renamed[stem + "_rad"] = values / units.DEG if name.endswith("_rad") else values
        else:
            renamed[name] = values
    c.write(table, renamed)
    return f"{table}: roll, pitch, yaw in degrees under _rad", refuse(
        c.base.file(table), ("roll_rad", "pitch_rad", "yaw_rad"))


@hostile("reference velocity in knots", "units and signs", REFUSE, fits=lambda b: b.reference is not None)
def _knots(c: Ctx) -> tuple[str, Expect]:
    return _scale(c, "reference", REF_VEL, 1.0 / KNOT_MPS, "in knots")


@hostile("negative reference depth", "units and signs", REFUSE, fits=lambda b: b.reference is not None)
def _negative_depth(c: Ctx) -> tuple[str, Expect]:
    return _scale(c, "reference", (c.base.ref_depth(),), -1.0, "negated (height, not depth)")


@hostile("latitude out of range", "units and signs", REFUSE, fits=lambda b: b.reference in ("rad", "deg"))
def _latitude(c: Ctx) -> tuple[str, Expect]:
    column = "lat_rad" if c.base.reference == "rad" else "lat_deg"
    row = c.row("reference")
    deg = float(c.choice([95.0, -95.0, 120.0, 181.0, -270.0, 400.0]))
    value = deg * units.DEG if column == "lat_rad" else deg
    c.set_cell("reference", column, row, repr(value), value)
    return f"reference: column {column!r}, row {row}: latitude {deg:g} deg", refuse(
        c.base.file("reference"), column, number_texts(value) + number_texts(deg), rows=(row,))


@hostile("dvl velocity in cm/s", "units and signs", REFUSE)
def _dvl_cms(c: Ctx) -> tuple[str, Expect]:
    return _scale(c, "dvl", c.base.dvl_velocity(), 100.0, "in cm/s")


# ========================================================================================== benign
@hostile("unchanged", "benign", ACCEPT)
def _unchanged(c: Ctx) -> tuple[str, Expect]:
    return "the base log as written", accept()


@hostile("columns reordered", "benign", ACCEPT)
def _reordered(c: Ctx) -> tuple[str, Expect]:
    done = []
    for table in c.tables():
        if c.choice([True, True, False]):
            cols = c.columns(table)
            order = [list(cols)[i] for i in c.rng.permutation(len(cols))]
            c.write(table, {n: cols[n] for n in order})
            done.append(f"{table} ({', '.join(order[:3])}, ...)")
    return "columns reordered: " + ("; ".join(done) or "none"), accept()


@hostile("whitespace around cells", "benign", ACCEPT, fits=is_csv)
def _whitespace(c: Ctx) -> tuple[str, Expect]:
    table = c.choice(c.tables())
    pads = [" ", "  ", "\t", " \t"]
    lines = c.lines(table)
    for k in range(1, len(lines)):
        fields = lines[k].split(",")
        lines[k] = ",".join(c.choice(pads) + f + c.choice(pads) if f else f for f in fields)
    c.write_lines(table, lines)
    return f"{table}: spaces and tabs around every cell", accept()


@hostile("parquet for csv", "benign", ACCEPT, fits=is_csv)
def _parquet(c: Ctx) -> tuple[str, Expect]:
    tables = [t for t in c.tables() if c.choice([True, False])] or ["imu"]
    for table in tables:
        c.write(table, c.columns(table), "parquet")
    return f"as Parquet: {', '.join(tables)}", accept()


@hostile("valid as true/false", "benign", ACCEPT, fits=lambda b: b.dvl == "body" and b.fmt == "csv")
def _valid_text(c: Ctx) -> tuple[str, Expect]:
    lines = c.lines("dvl")
    index = lines[0].split(",").index("valid")
    word = c.choice([("true", "false"), ("True", "False")])
    for k in range(1, len(lines)):
        fields = lines[k].split(",")
        fields[index] = word[0] if float(fields[index]) == 1.0 else word[1]
        lines[k] = ",".join(fields)
    c.write_lines("dvl", lines)
    return f"dvl: valid written {word[0]}/{word[1]}", accept()


@hostile("good log.toml", "benign", ACCEPT)
def _good_log_config(c: Ctx) -> tuple[str, Expect]:
    text = c.choice(["[dvl]\nnoise_mps = 0.05\n", "[dvl]\nlever_arm_m = [0.5, 0.0, 0.1]\n",
                     "# the log's own tuning\n[imu]\ngyro_bias_deg_per_h = 5.0\n"])
    (c.dir / "log.toml").write_text(text)
    return f"log.toml: {text!r}", accept()


# ========================================================================================= drawing
@dataclass(frozen=True)
class Case:
    klass: HostileClass
    index: int
    base: Base
    mutation: str
    expect: Expect
    flags: tuple[str, ...]

    @property
    def label(self) -> str:
        return f"[{self.klass.family} / {self.klass.name} #{self.index}] {self.base.name}: {self.mutation}"


FLAG_VARIANTS = [("--method", "ins,lc")] * 3 + [("--beams", "1,2", "--method", "tc"),
                                               ("--method", "ins,lc", "--config", "{config}")]
"""The replay's flags: mostly ``--method ins,lc``; sometimes TC on beams 1 and 2, or a
``--config`` file laid over the log."""


def class_seed(klass: HostileClass, tier: str) -> list[int]:
    """The seed of a class's cases: its position in the list would move when a class is added,
    its name does not."""
    return [sum(ord(ch) * 31**i for i, ch in enumerate(klass.name)) % 2**32, {"fast": 0, "slow": 1}[tier]]


def plan(klass: HostileClass, bases: list[Base], n: int, tier: str) -> list[tuple[Base, np.random.Generator]]:
    """The ``n`` cases of a class as (base, generator) pairs, the fitting bases taken in turn; each
    case is made just before it runs (:func:`make_case`)."""
    rng = np.random.default_rng(class_seed(klass, tier))
    fitting = [b for b in bases if klass.fits(b)]
    start = int(rng.integers(len(fitting)))
    return [(fitting[(start + i) % len(fitting)], np.random.default_rng(int(rng.integers(2**63))))
            for i in range(n)]


def make_case(klass: HostileClass, index: int, base: Base, rng: np.random.Generator, case_dir: Path) -> Case:
    """Copy ``base`` into ``case_dir`` (which must not exist) and break it as ``klass`` does."""
    shutil.copytree(base.directory, case_dir, symlinks=True)
    ctx = Ctx(rng, base, case_dir)
    mutation, expect = klass.make(ctx)
    flags = base.flags + FLAG_VARIANTS[int(rng.integers(len(FLAG_VARIANTS)))]
    return Case(klass, index, base, mutation, expect, flags)

