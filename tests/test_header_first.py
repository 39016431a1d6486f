"""Table readers refuse a wrong header at line 1 without reading the rest of the file (issue 23).

A 200 MB file whose first line is not the expected header: each reader must name line 1 and
its header, while the peak of Python's traced memory stays far below the file's size (a
reader that read the file first, as ``read_text_lines`` does, holds all of it).  The file's
rows are 60,000-character lines, so that a reader reading further would show at once.
"""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from pcmm_geo.errors import FileFormatError

FILE_MB = 200
#: peak traced memory allowed while refusing the header (the first block is 64 kB)
HEADER_PEAK_BYTES = 2 << 20


@pytest.fixture(scope="module")
def big_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("big") / "table.csv"
    row = ",".join(["12.345"] * 8_571) + "\n"  # 59,997 characters
    block = (row * ((1 << 20) // len(row) + 1)).encode()  # about 1 MiB
    with open(path, "wb") as handle:
        handle.write(b"this,is,not,the,header\n")
        for _ in range(FILE_MB * (1 << 20) // len(block)):
            handle.write(block)
        handle.write(b"# reference_diameter_mm: 25.0004\n")
    assert path.stat().st_size > FILE_MB * 10**6
    return path


def _peak(call: Callable[[], Any]) -> tuple[Any, int]:
    tracemalloc.start()
    try:
        try:
            result: Any = call()
        except FileFormatError as exc:
            result = exc
        return result, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _readers() -> dict[str, tuple[Callable[[Path], Any], str]]:
    from pcmm_geo.machine.analysis.repeatability import read_arm_table_csv, read_start_readings_csv
    from pcmm_geo.machine.calibration.numerical.numcal_data import read_numcal_csv
    from pcmm_geo.machine.calibration.probings import read_lasers, read_probings

    return {
        "probings": (read_probings, "expected header 'feature,position,x,y,z' or 'x,y,z,d,r'"),
        "lasers": (read_lasers, "expected header 'position,laser_a,laser_b,laser_c'"),
        "numcal": (read_numcal_csv, "expected header 'moved,laser_a,laser_b,laser_c,height'"),
        "repeatability": (lambda p: read_arm_table_csv(p, ("label", "laser_a", "laser_b", "laser_c")),
                          "expected header 'label,laser_a,laser_b,laser_c'"),
        "start readings": (read_start_readings_csv, "expected header 'test,laser_a,laser_b,laser_c'"),
    }


@pytest.mark.parametrize("reader", list(_readers()))
def test_wrong_header_is_refused_at_line_1_in_bounded_memory(big_file: Path, reader: str) -> None:
    read, message = _readers()[reader]
    error, peak = _peak(lambda: read(big_file))
    assert isinstance(error, FileFormatError), error
    assert error.line == 1 and message in error.reason and "this,is,not,the,header" in error.reason
    assert peak < HEADER_PEAK_BYTES, f"{reader}: {peak / 2**20:.1f} MiB traced while refusing line 1"


def test_reference_diameter_comment_found_anywhere_in_bounded_memory(big_file: Path) -> None:
    """The ``# reference_diameter_mm`` comment may stand after the data: the whole file is scanned, block by block."""
    from pcmm_geo.artefacts.iso10360_5 import read_reference_diameter

    diameter, peak = _peak(lambda: read_reference_diameter(big_file))
    assert diameter == 25.0004
    assert peak < 32 << 20, f"{peak / 2**20:.1f} MiB traced scanning a {FILE_MB} MB file"


def test_reference_diameter_still_checks_the_comment_lines(tmp_path: Path) -> None:
    from pcmm_geo.artefacts.iso10360_5 import read_reference_diameter

    path = tmp_path / "sphere.csv"
    path.write_text("x,y,z\n1,2,3\n" * 3 + "# reference_diameter_mm: 25\n4,5,6\n# reference_diameter_mm: 26\n")
    with pytest.raises(FileFormatError, match="reference_diameter_mm stated twice") as info:
        read_reference_diameter(path)
    assert info.value.line == 9
    path.write_bytes(b"x,y,z\n1,2,3\n# reference_diameter_mm: 2\xb55\n")
    with pytest.raises(FileFormatError, match="not UTF-8 text") as info:
        read_reference_diameter(path)
    assert info.value.line == 3
    path.write_text("x,y,z\n1,2,3\n")
    assert read_reference_diameter(path) is None
