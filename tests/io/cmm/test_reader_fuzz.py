"""Mutations of the public and shipped samples through every CMM reader (issue 31).

Each mutant (bytes flipped, inserted, deleted, a cut, a duplicated slice) is either read or
refused with a :class:`~pcmm_geo.errors.PcmmGeoError`; never another exception (a traceback on
the command line), never a hang (a generous alarm guards each reader call).  Kept small:
60 examples per reader, seeded by hypothesis' derandomised profile.
"""

from __future__ import annotations

import signal
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pcmm_geo.errors import PcmmGeoError
from pcmm_geo.io.cmm import read_calypso_table, read_dmis, read_pcdmis_xyzijk, read_qif

DATA = Path(__file__).resolve().parents[2] / "data"
SOURCES: dict[str, tuple[Path, Callable[[Path], object]]] = {
    "qif": (DATA / "qif" / "samples" / "mitutoyo_results_serialized_pass_fail_sample.QIF", read_qif),
    "qif_points": (DATA / "qif" / "samples" / "QIF_PTS_SAMPLE.QIF", read_qif),
    "dmis": (DATA / "cmm" / "standard.dmo", lambda p: read_dmis(p, size_values="deviation")),
    "geopak": (DATA / "cmm" / "geopak_style.dmo", lambda p: read_dmis(p, units="inch", angle_unit="degree")),
    "calypso": (DATA / "cmm" / "flange_chr.txt", lambda p: read_calypso_table(p, units="mm", angle_unit="degree")),
    "pcdmis": (DATA / "cmm" / "ring_xyzijk_metric.xyz", read_pcdmis_xyzijk),
}
NOISE = [b"", b"\x00", b"$", b"$$", b",", b"\t", b"\n", b"<", b">", b"/>", b"1e308", b"-", b"nan", b"3_3",
         "\u0663".encode(), b"\xff\xfe", b")", b"(", b"=", b"</Points>", b"<Diameter>1</Diameter>", b"END\n"]


@contextmanager
def _guard(seconds: int) -> Iterator[None]:
    def _expired(signum: int, frame: object) -> None:
        raise TimeoutError(f"a reader ran longer than {seconds} s")

    previous = signal.signal(signal.SIGALRM, _expired)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _mutate(data: bytes, edits: list[tuple[int, int, int, bytes]]) -> bytes:
    for kind, where, length, noise in edits:
        at = where % (len(data) + 1)
        if kind == 0:  # insert
            data = data[:at] + noise + data[at:]
        elif kind == 1:  # delete
            data = data[:at] + data[at + length:]
        elif kind == 2:  # replace
            data = data[:at] + noise + data[at + len(noise):]
        elif kind == 3:  # cut
            data = data[:at]
        else:  # duplicate a slice
            data = data[:at + length] + data[at:at + length] + data[at + length:]
    return data


EDITS = st.lists(st.tuples(st.integers(0, 4), st.integers(0, 1 << 20), st.integers(1, 40), st.sampled_from(NOISE)),
                 min_size=1, max_size=3)


@pytest.mark.parametrize("name", sorted(SOURCES))
@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(edits=EDITS)
def test_a_mutated_file_is_read_or_refused_with_a_typed_error(tmp_path: Path, name: str,
                                                              edits: list[tuple[int, int, int, bytes]]) -> None:
    source, reader = SOURCES[name]
    path = tmp_path / f"mutant{source.suffix}"
    path.write_bytes(_mutate(source.read_bytes(), edits))
    with _guard(30):
        try:
            reader(path)
        except PcmmGeoError as exc:
            message = str(exc)
            assert message.startswith(str(path)) and "\n" not in message and len(message) < 2_000
