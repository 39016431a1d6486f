"""DMIS reader under attack (issue 31): truncation, contradicting verdicts, overflow, negative sizes, long lines."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io.cmm import read_dmis
from pcmm_geo.io.cmm._dmis_syntax import MAX_STATEMENT_CHARS

DATA = Path(__file__).resolve().parents[2] / "data" / "cmm"
STANDARD = DATA / "standard.dmo"


def _write(tmp_path: Path, text: str, name: str = "cut.dmo") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8"))
    return path


@contextmanager
def _deadline(seconds: int) -> Iterator[None]:
    """A generous guard against a hang (the assertion is on the result, never on the time taken)."""
    def _expired(signum: int, frame: object) -> None:
        raise TimeoutError(f"still running after {seconds} s")

    previous = signal.signal(signal.SIGALRM, _expired)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def test_a_file_cut_inside_a_line_is_refused_at_every_such_cut(tmp_path: Path) -> None:
    """Every cut inside a statement's line (not at a line end) is refused naming the last line; none is read."""
    text = STANDARD.read_text(encoding="utf-8")
    line_starts = {0} | {i + 1 for i, c in enumerate(text) if c == "\n"}
    cuts = [k for k in range(1, len(text)) if k not in line_starts and text[k - 1] not in "\n"]
    refused = 0
    for cut in cuts[::7]:
        piece = text[:cut]
        last_line = piece.count("\n") + 1
        code = piece.rsplit("\n", 1)[-1].split("$$")[0].strip()
        if not code:  # cut inside a comment: nothing of a statement is lost
            continue
        with pytest.raises(FileFormatError) as caught:
            read_dmis(_write(tmp_path, piece))
        assert caught.value.line is not None and caught.value.line <= last_line
        refused += 1
    assert refused > 50


def test_the_torn_number_of_the_issue_is_refused(tmp_path: Path) -> None:
    """11.113 cut to 11.1 (no line end after it): refused, never read as 11.1 mm."""
    text = "UNITS/MM,ANGDEC\nFA(C)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,11.1"
    with pytest.raises(FileFormatError, match="ends in the middle of a line") as caught:
        read_dmis(_write(tmp_path, text))
    assert caught.value.line == 2


def test_a_missing_endfil_is_reported_not_refused(tmp_path: Path) -> None:
    text = STANDARD.read_text(encoding="utf-8")
    assert "ENDFIL" in text
    whole = read_dmis(STANDARD)
    assert not any("ENDFIL" in p for p in whole.problems)
    cut = read_dmis(_write(tmp_path, text.replace("ENDFIL\n", "")))
    assert any("no ENDFIL" in p for p in cut.problems)
    # cut exactly at a line end before ENDFIL: the undetectable class, only the missing ENDFIL says so
    lines = text.splitlines(keepends=True)
    shorter = read_dmis(_write(tmp_path, "".join(lines[:-4])))
    assert len(shorter.characteristics) == len(whole.characteristics) - 2
    assert any("no ENDFIL" in p for p in shorter.problems)


def test_a_contradicting_verdict_is_refused(tmp_path: Path) -> None:
    """TA(F)=TOL/FLAT,0.5,INTOL against T(F)=TOL/FLAT,0.01: a 0.5 mm flatness is not within a 0.01 mm zone."""
    head = "UNITS/MM,ANGDEC\nT(F)=TOL/FLAT,0.01\n"
    with pytest.raises(FileFormatError, match=r"INTOL contradicts the result 0\.5") as caught:
        read_dmis(_write(tmp_path, head + "TA(F)=TOL/FLAT,0.5,INTOL\nENDFIL\n"))
    assert caught.value.line == 3
    with pytest.raises(FileFormatError, match="OUTOL contradicts"):
        read_dmis(_write(tmp_path, head + "TA(F)=TOL/FLAT,0.004,OUTOL\nENDFIL\n"))
    # consistent verdicts and the rounding of the numbers written (0.0100 vs 0.01) pass
    for result in ("TA(F)=TOL/FLAT,0.0100,INTOL", "TA(F)=TOL/FLAT,0.0101,OUTOL", "TA(F)=TOL/FLAT,0.004,INTOL"):
        document = read_dmis(_write(tmp_path, head + result + "\nENDFIL\n"))
        assert document.characteristics[0].status == ("FAIL" if "OUTOL" in result else "PASS")


def test_a_contradicting_size_verdict_is_refused_and_mmc_is_left_unchecked(tmp_path: Path) -> None:
    head = "UNITS/MM,ANGDEC\nT(D)=TOL/DIAM,12,-0.01,0.015\n"
    with pytest.raises(FileFormatError, match="INTOL contradicts"):
        read_dmis(_write(tmp_path, head + "TA(D)=TOL/DIAM,0.030,INTOL\nENDFIL\n"), size_values="deviation")
    with pytest.raises(FileFormatError, match="INTOL contradicts"):
        read_dmis(_write(tmp_path, head + "TA(D)=TOL/DIAM,12.030,INTOL\nENDFIL\n"), size_values="actual")
    assert read_dmis(_write(tmp_path, head + "TA(D)=TOL/DIAM,12.005,INTOL\nENDFIL\n"),
                     size_values="actual").characteristics[0].value == 12.005
    # position at MMC: the bonus tolerance depends on the actual size, so 0.06 may pass a 0.05 zone
    mmc = "UNITS/MM,ANGDEC\nT(P)=TOL/POS,3D,0.05,MMC\nTA(P)=TOL/POS,3D,0.06,INTOL\nENDFIL\n"
    assert read_dmis(_write(tmp_path, mmc)).characteristics[0].status == "PASS"


@pytest.mark.parametrize("statement", [
    "FA(C)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,-12.5",
    "FA(S)=FEAT/SPHERE,OUTER,CART,0,0,0,-25",
    "FA(Y)=FEAT/CYLNDR,OUTER,CART,0,0,0,0,0,1,8,-15",
])
def test_a_negative_size_is_refused(tmp_path: Path, statement: str) -> None:
    with pytest.raises(FileFormatError, match=">= 0, got -") as caught:
        read_dmis(_write(tmp_path, f"UNITS/MM,ANGDEC\n{statement}\nENDFIL\n"))
    assert caught.value.line == 2


@pytest.mark.parametrize("statement", [
    "FA(C)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,1e307",
    "FA(P)=FEAT/POINT,CART,1e307,0,0,0,0,1",
    "T(F)=TOL/FLAT,1e307",
])
def test_a_value_that_overflows_in_mm_is_refused(tmp_path: Path, statement: str) -> None:
    """1e307 feet is 3e309 mm: beyond the float range (it used to read as inf and PASS)."""
    with pytest.raises(FileFormatError, match="overflows the float range"):
        read_dmis(_write(tmp_path, f"UNITS/FEET,ANGDEC\n{statement}\nENDFIL\n"))


def test_a_long_hostile_line_is_read_in_linear_time(tmp_path: Path) -> None:
    """'FA(' + spaces + 'X' took minutes (backtracking patterns); now one pass: refused at once."""
    for text in ("FA(" + " " * 60_000 + "X", "OUTPUT/" + "FA(" * 20_000, "FA(A" + " " * 60_000 + ")=FEAT/",
                 "FA(" + " " * 4_000 + "X", "FA(" + " " * 100_000 + "X"):
        with _deadline(20), pytest.raises(FileFormatError) as caught:
            read_dmis(_write(tmp_path, "UNITS/MM\n" + text + "\nENDFIL\n"))
        assert caught.value.line == 2 and len(str(caught.value)) < 500


def test_continued_lines_are_bounded(tmp_path: Path) -> None:
    line = "0," * 1000 + "$\n"
    text = "UNITS/MM\nFA(P)=FEAT/POINT,CART,$\n" + line * (MAX_STATEMENT_CHARS // 2000 + 2) + "0\nENDFIL\n"
    with _deadline(20), pytest.raises(FileFormatError, match=f"more than {MAX_STATEMENT_CHARS} characters") as caught:
        read_dmis(_write(tmp_path, text))
    assert caught.value.line == 2
