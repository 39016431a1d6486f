"""Durable acquisition log: header, exclusive creation, fsync per row, torn rows, SIGKILL."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pcmm_geo.acquisition import acqlog
from pcmm_geo.acquisition.acqlog import LOG_COLUMNS, AcquisitionLog, LogRow, read_log
from pcmm_geo.errors import InvalidInputError, LogIntegrityError, OutputExistsError


def _row(i: int) -> LogRow:
    return LogRow(i % 2, 0, 1 + i % 3, 1 if i % 4 < 2 else -1, 10.0 + i, 20.5, 30.25,
                  pos_usteps=(247500 + i, 247500, 247500), laser_raw=(1000 + i, 2000, 3000))


def test_header_metadata_and_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    with AcquisitionLog.create(path, {"settle_s": 2.6, "ports": "zaber=COM11"}) as log:
        written = [log.append(_row(i)) for i in range(3)]
    text = path.read_text()
    lines = text.splitlines()
    assert lines[0] == "# pcmm_geo acquisition log"
    header_line = next(line for line in lines if not line.startswith("#"))
    assert header_line.split(",")[:7] == ["start_stop", "probe", "motor", "direction", "laser_a", "laser_b", "laser_c"]
    contents = read_log(path)
    assert contents.metadata["settle_s"] == "2.6" and contents.metadata["ports"] == "zaber=COM11"
    assert contents.metadata["schema"] == acqlog.LOG_SCHEMA
    assert contents.metadata["software"].startswith("pcmm_geo ")
    assert contents.metadata["created_utc"].endswith("Z")
    assert "mm" in contents.metadata["unit.laser_a"]
    assert contents.rows == tuple(written)
    assert [r.seq for r in contents.rows] == [0, 1, 2]
    assert contents.rows[2].laser_a == 12.0 and contents.rows[2].pos_usteps == (247502, 247500, 247500)
    # the Table 3.2 part of a row, exactly as the thesis orders it
    assert lines[-1].split(",")[:7] == ["0", "0", "3", "-1", "12.0", "20.5", "30.25"]
    assert text.endswith("\n") and "\r" not in text


def test_refuses_to_overwrite(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    path.write_text("precious\n")
    with pytest.raises(OutputExistsError, match="refusing to overwrite"):
        AcquisitionLog.create(path)
    assert path.read_text() == "precious\n"
    with AcquisitionLog.create(path, overwrite=True) as log:
        log.append(_row(0))
    assert len(read_log(path).rows) == 1


def test_every_row_is_fsynced(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    synced: list[int] = []
    real_fsync = os.fsync
    monkeypatch.setattr(acqlog.os, "fsync", lambda fd: (synced.append(fd), real_fsync(fd))[1])
    with AcquisitionLog.create(tmp_path / "run.csv") as log:
        after_header = len(synced)
        for i in range(4):
            log.append(_row(i))
            assert len(synced) == after_header + i + 1


def test_partial_last_row_is_detected_and_repaired(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    with AcquisitionLog.create(path) as log:
        for i in range(2):
            log.append(_row(i))
    torn = "1,0,2,1,49.23"
    with open(path, "a", encoding="utf-8") as handle:
        handle.write(torn)
    with pytest.raises(LogIntegrityError, match="partial last row"):
        read_log(path)
    with pytest.raises(LogIntegrityError, match="partial last row"):
        AcquisitionLog.resume(path)
    assert path.read_text().endswith(torn)  # nothing changed without repair
    report = read_log(path, allow_partial=True).recovery
    assert (report.rows, report.truncated, report.dropped_bytes, report.dropped_text) == (2, True, len(torn), torn)
    with AcquisitionLog.resume(path, repair=True) as log:
        assert log.recovery.dropped_bytes == len(torn)
        log.append(_row(7))
    contents = read_log(path)
    assert [r.seq for r in contents.rows] == [0, 1, 2]
    assert contents.metadata["truncated_bytes"] == str(len(torn))
    assert torn not in path.read_text()


def test_damaged_rows_and_headers_are_reported_with_line_numbers(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    with AcquisitionLog.create(path) as log:
        log.append(_row(0))
    lines = path.read_text().splitlines(keepends=True)
    bad = [*lines[:-1], lines[-1].replace("20.5", "20.5x")]
    path.write_text("".join(bad))
    with pytest.raises(LogIntegrityError) as info:
        read_log(path)
    assert info.value.line == len(lines)
    path.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(LogIntegrityError, match="expected column header"):
        AcquisitionLog.resume(path)


def test_row_validation() -> None:
    with pytest.raises(InvalidInputError, match="motor"):
        LogRow(1, 0, 4, 1, 1.0, 2.0, 3.0)
    with pytest.raises(InvalidInputError, match="laser_b"):
        LogRow(1, 0, 1, 1, 1.0, float("nan"), 3.0)
    with pytest.raises(InvalidInputError, match="metadata"):
        AcquisitionLog.create("unused.csv", {"note": "two\nlines"})


_WRITER = """
import sys
from pcmm_geo.acquisition.acqlog import AcquisitionLog, LogRow
with AcquisitionLog.create(sys.argv[1]) as log:
    i = 0
    while True:
        log.append(LogRow(i % 2, 0, 1, 1, 12.345678 + i, 23.456789, 34.567891,
                          pos_usteps=(i, 2 * i, 3 * i), laser_raw=(i, i, i)))
        i += 1
"""


def test_writer_killed_with_sigkill_leaves_only_whole_rows(tmp_path: Path) -> None:
    path = tmp_path / "killed.csv"
    process = subprocess.Popen([sys.executable, "-c", _WRITER, str(path)])
    try:
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            if path.exists() and path.read_bytes().count(b"\n") > 200:
                break
            time.sleep(0.02)
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=10)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == -signal.SIGKILL
    contents = read_log(path)  # strict: raises on any partial or damaged row
    count = len(contents.rows)
    assert count > 150
    assert [r.seq for r in contents.rows] == list(range(count))
    assert all(r.pos_usteps == (r.seq, 2 * r.seq, 3 * r.seq) for r in contents.rows)
    assert contents.columns == LOG_COLUMNS


def test_table_3_2_export_reads_with_the_log_processor(tmp_path: Path) -> None:
    from pcmm_geo.machine.analysis.logproc import read_log as read_table_3_2

    with AcquisitionLog.create(tmp_path / "run.csv", {"seed": 1}) as log:
        for i in range(5):
            log.append(_row(i))
    table = acqlog.export_table_3_2(tmp_path / "run.csv", tmp_path / "table.csv")
    parsed = read_table_3_2(table)
    assert parsed.motor.tolist() == [1, 2, 3, 1, 2]
    assert parsed.direction.tolist() == [1, 1, -1, -1, 1]
    assert parsed.lasers[:, 0].tolist() == [10.0, 11.0, 12.0, 13.0, 14.0]
    with pytest.raises(OutputExistsError, match="refusing to overwrite"):
        acqlog.export_table_3_2(tmp_path / "run.csv", table)
