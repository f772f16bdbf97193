"""`tauv run --save-log` written as the run goes (tauvcore.logs.writer.LogWriter): the same files as
the whole-log writer (write_log of simulation_tables) on the same chunks, CSV byte for byte and
Parquet value for value, and all or nothing."""

from __future__ import annotations

import dataclasses
import errno
import os
from pathlib import Path

import numpy as np
import pytest

from app import cli
from tauvcore.config import Config, to_log_toml
from tauvcore.engine import mission
from tauvcore.logs import CONFIG_FILE, read_log
from tauvcore.logs import writer as log_writer
from tauvcore.logs.writer import LogWriter, chunk_tables, simulation_tables, write_log

ARGV = ["run", "--trajectory", "figure8", "--duration", "25", "--method", "ins,lc", "--aiding", "dvl,depth,mag,usbl"]
"""A short mission with every table a simulated log has, and the USBL's (whose first fix comes after
the first chunks: a table whose first chunks are empty)."""


def _files(directory: Path) -> dict[str, bytes]:
    """Every file below ``directory`` (hidden ones too) and its content."""
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


def _assert_same_log(streamed: Path, whole: Path, fmt: str) -> None:
    assert sorted(os.listdir(streamed)) == sorted(os.listdir(whole))
    if fmt == "csv":
        assert _files(streamed) == _files(whole)                       # byte for byte
        return
    import pyarrow.parquet as pq

    assert _files(streamed).get(CONFIG_FILE) == _files(whole).get(CONFIG_FILE)
    for name in (n for n in os.listdir(whole) if n.endswith(".parquet")):
        a, b = pq.read_table(streamed / name), pq.read_table(whole / name)
        assert a.schema == b.schema, name
        assert a.equals(b), name                                     # value for value, NaN where NaN
        for column in a.column_names:
            np.testing.assert_array_equal(a[column].to_numpy(), b[column].to_numpy(), err_msg=f"{name} {column}")


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_tauv_run_save_log_writes_what_the_whole_log_writer_writes(capsys, tmp_path, monkeypatch, fmt) -> None:
    """The command's streamed log against write_log(simulation_tables(chunks)) of the very chunks the
    command simulated (what the command wrote before it streamed)."""
    chunks: list = []
    configs: list = []
    real = mission.run_streaming

    def keeping(*args, sinks=mission.NO_SINKS, **kwargs):
        configs.append(args[0])

        def both(chunk):
            chunks.append(chunk)
            sinks.on_sim_chunk(chunk)
        return real(*args, sinks=dataclasses.replace(sinks, on_sim_chunk=both), **kwargs)

    monkeypatch.setattr(mission, "run_streaming", keeping)
    assert cli.main([*ARGV, "--save-log", str(tmp_path / "streamed"), "--log-format", fmt]) == 0
    assert len(chunks) == 3                                            # 25 s in 10 s chunks
    assert chunk_tables(chunks[0])["usbl"]["t_s"].size == 0            # a table that starts empty
    write_log(tmp_path / "whole", simulation_tables(chunks), fmt, config_toml=to_log_toml(configs[0]))
    _assert_same_log(tmp_path / "streamed", tmp_path / "whole", fmt)
    assert read_log(tmp_path / "streamed").duration_s == pytest.approx(25.0)
    assert (tmp_path / "streamed" / CONFIG_FILE).is_file()                # the run's own configuration


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
@pytest.mark.parametrize("earth", ["wgs84", "flat"])
def test_the_log_writer_on_odd_chunks_is_the_whole_writer(tmp_path, monkeypatch, fmt, earth) -> None:
    """Chunks ending mid-interval (of the DVL, the depth, the magnetometer), a geodetic or a local
    reference, the log's own configuration file, Parquet row groups that gather several chunks
    (here 2,000 rows at least): the same files."""
    monkeypatch.setattr(log_writer, "ROW_GROUP_ROWS", 2000)
    config = (Config().replace("trajectory", name="lawnmower", duration_s=30.0).replace("earth", model=earth)
              .replace("run", methods=("lc",), aiding=("dvl", "depth", "mag")))
    chunks: list = []
    writer = LogWriter(tmp_path / "streamed", fmt, config_toml="[dvl]\nnoise_mps = 0.01\n")

    def add(chunk):
        chunks.append(chunk)
        writer.add(chunk_tables(chunk))

    mission.run_streaming(config, np.random.default_rng(2), chunk_s=3.7, keep=False, sinks=mission.Sinks(on_sim_chunk=add))
    writer.finish()
    assert len(chunks) == 9
    write_log(tmp_path / "whole", simulation_tables(chunks), fmt, config_toml="[dvl]\nnoise_mps = 0.01\n")
    _assert_same_log(tmp_path / "streamed", tmp_path / "whole", fmt)
    if fmt == "parquet":
        import pyarrow.parquet as pq

        imu = pq.ParquetFile(tmp_path / "streamed" / "imu.parquet")      # 4,501 rows in chunks of 555
        assert [imu.metadata.row_group(i).num_rows for i in range(imu.num_row_groups)] == [2220, 2220, 61]


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
@pytest.mark.parametrize("failure", [OSError(errno.ENOSPC, "No space left on device"), KeyboardInterrupt()])
def test_a_log_writer_failing_mid_way_leaves_nothing(tmp_path, monkeypatch, fmt, failure) -> None:
    """A failure while appending, or while putting the files in place, leaves no file, no temporary
    and none of the directories the writer made; a file that was there is untouched."""
    config = Config().replace("trajectory", duration_s=25.0).replace("run", methods=("ins",))
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("mine")
    for where in ("append", "finish"):
        for target in (tmp_path / "new" / "log", tmp_path / "mine"):
            writer = LogWriter(target, fmt)
            calls = {"n": 0}
            real_append = log_writer._TableFile.append

            def append(self, columns, real_append=real_append, calls=calls, where=where):
                calls["n"] += 1
                if where == "append" and calls["n"] == 9:              # in the second chunk
                    raise failure
                real_append(self, columns)

            monkeypatch.setattr(log_writer._TableFile, "append", append)
            if where == "finish":
                monkeypatch.setattr(log_writer, "fsync_path", _fail(failure))
            with pytest.raises(type(failure)):
                try:
                    mission.run_streaming(config, np.random.default_rng(0), keep=False, sinks=mission.Sinks(on_sim_chunk=lambda c, w=writer: w.add(chunk_tables(c))))
                    writer.finish()
                except BaseException:
                    writer.discard()
                    raise
            monkeypatch.undo()
            assert sorted(os.listdir(tmp_path)) == ["mine"], (where, target)
            assert _files(tmp_path / "mine") == {"notes.txt": b"mine"}, (where, target)


def _fail(failure: BaseException):
    def fail(*args, **kwargs):
        raise failure
    return fail


def test_a_chunk_whose_columns_change_is_refused(tmp_path) -> None:
    writer = LogWriter(tmp_path / "log")
    writer.add({"depth": {"t_s": np.arange(2.0), "depth_m": np.ones(2)}})
    with pytest.raises(ValueError, match="depth: a chunk's columns"):
        writer.add({"depth": {"t_s": np.arange(2.0)}})
    with pytest.raises(ValueError, match="unknown table 'sonar'"):
        writer.add({"sonar": {"t_s": np.arange(2.0)}})
    writer.discard()
    assert os.listdir(tmp_path) == []
