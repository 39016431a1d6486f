"""``pcmm acquire`` outputs: checked before any device is touched, per-output overwrite, all-or-nothing, torn headers.

In-process runs of :func:`pcmm_geo.cli.main` on the simulated machine (``--transport virtual``:
simulated clock, deterministic); the session is instrumented to count homings and moves.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pcmm_geo.acquisition import acqlog
from pcmm_geo.acquisition.acqlog import AcquisitionLog, LogRow, read_log
from pcmm_geo.acquisition.session import AcquisitionSession
from pcmm_geo.cli import main
from pcmm_geo.errors import DeviceError, LogIntegrityError

FAST = ["acquire", "--simulate", "--transport", "virtual", "--settle", "0", "--seed", "3"]


@pytest.fixture
def work(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Counts of homings (``prepare``) and logged moves made by the sessions of the test."""
    counts = {"prepare": 0, "move": 0}
    prepare, move = AcquisitionSession.prepare, AcquisitionSession.move

    def counted_prepare(self: AcquisitionSession, **kwargs: bool) -> None:
        counts["prepare"] += 1
        prepare(self, **kwargs)

    def counted_move(self: AcquisitionSession, motor: int, steps: int) -> object:
        counts["move"] += 1
        return move(self, motor, steps)

    monkeypatch.setattr(AcquisitionSession, "prepare", counted_prepare)
    monkeypatch.setattr(AcquisitionSession, "move", counted_move)
    return counts


def _tree(folder: Path) -> dict[str, bytes | None]:
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None) for p in sorted(folder.rglob("*"))}


def _acquire(*args: str, moves: int = 4) -> int:
    return main([*FAST, "--moves", str(moves), *args])


def test_existing_table_is_refused_before_any_device_work(tmp_path: Path, work: dict[str, int],
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "table.csv").write_bytes(b"an earlier table\n")
    before = _tree(tmp_path)
    assert _acquire("--out", str(tmp_path / "run.csv"), "--table-3-2", str(tmp_path / "table.csv"), moves=50) == 2
    assert work == {"prepare": 0, "move": 0}  # refused before homing: no move of the 50
    assert _tree(tmp_path) == before  # no log created, the table untouched
    error = capsys.readouterr().err.strip()
    assert error == (f"pcmm acquire: error: {tmp_path / 'table.csv'}: already exists; refusing to overwrite "
                     "(use --overwrite-table-3-2 to replace it, or --overwrite for every output)")


def test_each_output_has_its_own_overwrite_permission(tmp_path: Path, work: dict[str, int]) -> None:
    log, table = tmp_path / "run.csv", tmp_path / "table.csv"
    assert _acquire("--out", str(log), "--table-3-2", str(table)) == 0 and work["move"] == 4
    first_log, first_table = log.read_bytes(), table.read_bytes()
    work["move"] = 0
    # the table may be replaced, the log may not: refused, nothing moved, both unchanged
    assert _acquire("--out", str(log), "--table-3-2", str(table), "--overwrite-table-3-2") == 2
    assert _acquire("--out", str(log), "--table-3-2", str(table), "--overwrite-out") == 2
    assert work["move"] == 0 and log.read_bytes() == first_log and table.read_bytes() == first_table
    # the log is appended to (--resume), only the table is replaced
    assert _acquire("--out", str(log), "--table-3-2", str(table), "--resume", "--overwrite-table-3-2", moves=2) == 0
    rows = read_log(log).rows
    assert len(rows) == 12 and [r.seq for r in rows] == list(range(12))
    assert log.read_bytes().startswith(first_log)  # earlier rows kept byte for byte
    assert len(table.read_text().splitlines()) == 1 + 12
    # both replaced with both flags (or --overwrite)
    assert _acquire("--out", str(log), "--table-3-2", str(table), "--overwrite-out", "--overwrite-table-3-2") == 0
    assert len(read_log(log).rows) == 8 and len(table.read_text().splitlines()) == 9
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv", "table.csv"]  # no backup left behind


def test_unwritable_later_output_leaves_nothing(tmp_path: Path, work: dict[str, int],
                                                capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "blocker").write_bytes(b"a file where a folder is needed\n")
    (tmp_path / "old.csv").write_bytes(b"pre-existing log\n")
    before = _tree(tmp_path)
    for out in ("new/run.csv", "old.csv"):
        code = _acquire("--out", str(tmp_path / out), "--overwrite-out",
                        "--table-3-2", str(tmp_path / "blocker" / "sub" / "table.csv"))
        assert code == 2
        assert "--table-3-2" in capsys.readouterr().err
    assert work == {"prepare": 0, "move": 0} and _tree(tmp_path) == before


def test_failure_after_work_rolls_back_but_keeps_measured_rows(tmp_path: Path, work: dict[str, int],
                                                               monkeypatch: pytest.MonkeyPatch,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    log, table = tmp_path / "run.csv", tmp_path / "table.csv"

    def disk_full(*args: object, **kwargs: object) -> Path:
        raise OSError(28, "No space left on device", str(table))

    monkeypatch.setattr(acqlog, "export_table_3_2", disk_full)
    assert _acquire("--out", str(log), "--table-3-2", str(table)) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith(f"pcmm acquire: error: {table}: No space left on device; kept {log}: 8 measured row(s)")
    assert len(read_log(log).rows) == 8 and not table.exists()  # the record stays, the derived view is not half-made

    # a failure before any row: the new log is removed, a log it replaced comes back byte for byte
    log.write_bytes(b"# an earlier log the user allowed to replace\n")
    before = _tree(tmp_path)

    def homing_fails(self: AcquisitionSession, **kwargs: bool) -> None:
        raise DeviceError("zaber device 1", "stage does not home")

    monkeypatch.setattr(AcquisitionSession, "prepare", homing_fails)
    assert _acquire("--out", str(log), "--overwrite", "--table-3-2", str(tmp_path / "new" / "t.csv")) == 2
    assert _tree(tmp_path) == before


def test_resume_of_a_log_torn_in_its_header_is_refused_before_homing(tmp_path: Path, work: dict[str, int],
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "run.csv"
    AcquisitionLog.create(log, {"settle_s": "0"}).close()
    header = log.read_bytes()
    torn = header[: header.index(b"# unit.laser_b") + 5]  # a crash while the header was written
    log.write_bytes(torn)
    assert _acquire("--out", str(log), "--resume", "--repair") == 2
    error = capsys.readouterr().err.strip()
    lines = torn.count(b"\n")
    assert error.startswith(f"pcmm acquire: error: {log}:{lines + 1}: incomplete header")
    assert log.read_bytes() == torn and work == {"prepare": 0, "move": 0}


def test_header_torn_anywhere_is_refused_or_provably_restored(tmp_path: Path) -> None:
    original = tmp_path / "original.csv"
    AcquisitionLog.create(original, {"settle_s": "2.6", "ports": "zaber=COM11"}).close()
    header = original.read_bytes()
    column_start = header.rindex(b"\n", 0, len(header) - 1) + 1
    path = tmp_path / "run.csv"
    restored = refused = 0
    for cut in range(len(header)):
        path.write_bytes(header[:cut])
        with pytest.raises(LogIntegrityError) as plain:
            read_log(path, allow_partial=True)
        assert plain.value.path == str(path) and plain.value.line == header[:cut].count(b"\n") + 1
        if cut > column_start:  # the comment header is whole, the fixed column line torn: completed
            with AcquisitionLog.resume(path, repair=True) as log:
                assert log.recovery.header_completed_bytes == len(header) - cut
                log.append(LogRow(1, 0, 2, 1, 49.5, 54.25, 67.5))
            text = path.read_bytes()
            assert text.startswith(header)  # identical to the header that was being written
            contents = read_log(path)
            assert len(contents.rows) == 1 and contents.metadata["header_completed_bytes"] == str(len(header) - cut)
            restored += 1
        else:
            with pytest.raises(LogIntegrityError, match="incomplete header") as error:
                AcquisitionLog.resume(path, repair=True)
            assert error.value.path == str(path) and error.value.line == header[:cut].count(b"\n") + 1
            assert path.read_bytes() == header[:cut]  # refused: not a byte changed
            refused += 1
    assert restored == len(header) - column_start - 1 and refused == column_start + 1


def test_repair_never_loses_recorded_rows(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    with AcquisitionLog.create(path) as log:
        written = [log.append(LogRow(i % 2, 0, 1, 1, 10.0 + i, 20.0, 30.0)) for i in range(5)]
    whole = path.read_bytes()
    last = whole.rindex(b"\n", 0, len(whole) - 1) + 1
    for cut in range(last + 1, len(whole)):  # the last row torn anywhere
        path.write_bytes(whole[:cut])
        with AcquisitionLog.resume(path, repair=True) as log:
            assert log.recovery.rows == 4 and log.recovery.dropped_bytes == cut - last
        assert [r.laser_a for r in read_log(path).rows] == [r.laser_a for r in written[:4]]
