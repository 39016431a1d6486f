"""read_points_lazy: the same points and the same refusals as read_points, found when computed."""

from __future__ import annotations

import pickle
from pathlib import Path

import dask.array as da
import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io import read_points, read_points_lazy


def _write(path: Path, points: np.ndarray, separator: str = ",", decimal: str = ".") -> Path:
    rows = [separator.join(f"{v:.6f}".replace(".", decimal) for v in p) for p in points]
    rows.insert(len(rows) // 3, "# a note between rows")
    rows.insert(len(rows) // 2, "")
    path.write_text(f"x{separator}y{separator}z\n" + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize(("separator", "decimal"), [(",", "."), (";", ","), ("\t", "."), (" ", ",")])
@pytest.mark.parametrize("chunk_bytes", [64, 1000, 1 << 20])
def test_lazy_equals_eager(tmp_path: Path, separator: str, decimal: str, chunk_bytes: int) -> None:
    points = np.round(np.random.default_rng(5).uniform(-300, 300, (500, 3)), 6)
    path = _write(tmp_path / "scan.txt", points, separator, decimal)
    lazy = read_points_lazy(path, chunk_bytes=chunk_bytes)
    assert isinstance(lazy, da.Array) and lazy.shape == (500, 3) and lazy.dtype == np.float64
    np.testing.assert_array_equal(lazy.compute(), read_points(path))
    np.testing.assert_array_equal(read_points(path), points)


def test_lazy_fit_equals_the_in_memory_fit(tmp_path: Path) -> None:
    from pcmm_geo.fit import fit_sphere
    from pcmm_geo.fit.reference import make_reference_data

    data = make_reference_data("sphere", n_points=3000, radius=25.0, form=0.01, offset=500.0, rng=9)
    path = tmp_path / "sphere.csv"
    path.write_text("".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in data.points.tolist()))
    lazy, eager = fit_sphere(read_points_lazy(path, chunk_bytes=20_000)), fit_sphere(data.points)
    np.testing.assert_allclose(lazy.center, eager.center, rtol=0, atol=1e-9)
    assert abs(lazy.radius - eager.radius) <= 1e-9


def test_a_bad_line_surfaces_at_compute_time_naming_its_line(tmp_path: Path) -> None:
    points = np.round(np.random.default_rng(6).uniform(-300, 300, (400, 3)), 6)
    path = _write(tmp_path / "scan.csv", points)
    lines = path.read_text().splitlines()
    lines[350] = lines[350].replace(",", ";", 1)
    path.write_text("\n".join(lines) + "\n")
    lazy = read_points_lazy(path, chunk_bytes=2000)  # the head is fine: no error yet
    assert lazy.numblocks[0] > 3
    with pytest.raises(FileFormatError, match="expected 3 values separated by ','") as info:
        lazy.compute()
    assert info.value.line == 351
    with pytest.raises(FileFormatError) as eager:
        read_points(path)
    assert eager.value.line == 351
    with pytest.raises(FileFormatError) as processes:  # the error crosses process boundaries whole
        lazy.compute(scheduler="processes", num_workers=2)
    assert processes.value.line == 351
    again = pickle.loads(pickle.dumps(info.value))
    assert (type(again), again.line, again.reason) == (FileFormatError, 351, info.value.reason)


def test_a_file_changed_after_opening_is_refused(tmp_path: Path) -> None:
    path = _write(tmp_path / "scan.csv", np.ones((50, 3)))
    lazy = read_points_lazy(path)
    with open(path, "a") as handle:
        handle.write("2,2,2\n")
    with pytest.raises(FileFormatError, match="changed after it was opened"):
        lazy.compute()


def test_head_problems_are_refused_at_once(tmp_path: Path) -> None:
    path = tmp_path / "log.csv"
    path.write_text("start_stop,probe,motor\n1,0,1\n")
    with pytest.raises(FileFormatError, match="header without x, y, z"):
        read_points_lazy(path)
    nist = tmp_path / "p.ds"
    nist.write_text("3\n1 2 3\n4 5 6\n")
    with pytest.raises(FileFormatError, match="announces 3 points, found 2"):
        read_points_lazy(nist)
