"""Recorded sensor logs, in one room: the format and its reader (:mod:`tauvcore.logs.reader`), the
assembled record (:mod:`~tauvcore.logs.log_record`), a table's file and its columns
(:mod:`~tauvcore.logs.table_io`, :mod:`~tauvcore.logs.columns`), the physical checks
(:mod:`~tauvcore.logs.checks`, :mod:`~tauvcore.logs.motion_checks`,
:mod:`~tauvcore.logs.evidence`), the writer (:mod:`~tauvcore.logs.writer`) and ROS bags read
into the same record (:mod:`tauvcore.logs.bags`).

The reader's names are this package's: ``from tauvcore.logs import read_log``.
"""

from tauvcore.logs.reader import (
    CONFIG_FILE,
    SOURCE_TABLES,
    TABLES,
    Log,
    LogError,
    find_logs,
    log_from_tables,
    raw_layout_hint,
    read_log,
)

__all__ = [
    "CONFIG_FILE",
    "SOURCE_TABLES",
    "TABLES",
    "Log",
    "LogError",
    "find_logs",
    "log_from_tables",
    "raw_layout_hint",
    "read_log",
]
