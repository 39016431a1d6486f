"""Every NIST least-squares reference pair in tests/data/nist, fitted by pcmm_geo within 1e-9 of NIST's values.

57 pairs: 37 ``<Type>/*.ds`` plus 20 ``extra-from-points-txt/<Type>/*.txt``.  NIST's values
are stated to be correct in every digit given, so they are independent truth.
Positions are compared across the line / axis / plane (NIST's reported point may sit
elsewhere along it), directions up to sign (cone axis: with sign), sizes directly, the
cone by its ``s`` and full apex angle at NIST's reported point.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.io.nist import iter_nist_pairs, read_nist_fit, read_nist_pair, read_nist_points
from pcmm_geo.testing import assert_fit_close, fit_deviations, fit_nist_pair

NIST_DIR = Path(__file__).resolve().parents[1] / "data" / "nist"
DATA_FILES = sorted([*NIST_DIR.glob("*/*.ds"), *NIST_DIR.glob("extra-from-points-txt/*/*.txt")])
TOLERANCE = 1e-9


def test_all_57_pairs_are_present() -> None:
    pairs = list(iter_nist_pairs(NIST_DIR))
    assert len(DATA_FILES) == 57 and len(pairs) == 57
    assert len(list(NIST_DIR.glob("*/*.ds"))) == 37
    # per-type counts of INDEX.md of the shared copy
    assert Counter(pair.element for pair in pairs) == {
        "circle3d": 7,
        "cone": 5,
        "cylinder": 7,
        "line2d": 12,
        "line3d": 8,
        "plane": 8,
        "sphere": 10,
    }


def test_reader_values_of_one_cone_by_hand() -> None:
    pair = read_nist_pair(NIST_DIR / "Cone" / "con17.ds")
    assert pair.points.shape == (45, 3)
    np.testing.assert_array_equal(pair.points[0], [64.59405, 751.85745, -631.62846])
    half_angle = math.radians(47.643790989135307208) / 2
    assert pair.parameters["half_angle"] == pytest.approx(half_angle, abs=1e-15)
    assert pair.parameters["s"] == 18.160478424281607296
    assert pair.parameters["radius_at_point"] == pytest.approx(18.160478424281607296 / math.cos(half_angle), rel=1e-15)
    expected_point = [62.439848805608234173, 758.71793674052405467, -614.9489421198702589]
    np.testing.assert_array_equal(pair.parameters["point"], expected_point)


def _check_cone(result, pair) -> None:
    """NIST's s and full apex angle, evaluated for the fitted cone at NIST's reported point."""
    params = pair.parameters
    axis = result.axis / np.linalg.norm(result.axis)
    station = float((params["point"] - result.point) @ axis)
    radius_there = result.radius_at_point + station * math.tan(result.half_angle)
    s_fitted = radius_there * math.cos(result.half_angle)
    assert abs(s_fitted - params["s"]) <= TOLERANCE
    assert abs(math.degrees(2 * result.half_angle) - params["apex_angle_deg"]) <= TOLERANCE


@pytest.mark.parametrize("data_path", DATA_FILES, ids=[p.stem for p in DATA_FILES])
def test_pcmm_fit_reproduces_nist_reference(data_path: Path) -> None:
    pair = read_nist_pair(data_path)
    result = fit_nist_pair(pair)
    assert result.converged
    deviations = fit_deviations(result, pair)
    assert max(deviations.values()) <= TOLERANCE, deviations
    assert_fit_close(result, pair, position_mm=TOLERANCE, angle_rad=TOLERANCE)
    if "diameter" in pair.parameters:
        assert abs(2 * result.radius - pair.parameters["diameter"]) <= TOLERANCE
    if pair.element == "cone":
        _check_cone(result, pair)
    if pair.element in ("line2d", "line3d", "plane"):
        # NIST reports the centroid: it lies on the fitted element
        assert deviations["point"] <= TOLERANCE


@pytest.mark.parametrize(
    "data_path",
    [p for p in DATA_FILES if p.parent.name == "Line2d"],
    ids=[p.stem for p in DATA_FILES if p.parent.name == "Line2d"],
)
def test_line2d_pairs_fitted_in_two_dimensions(data_path: Path) -> None:
    from pcmm_geo.fit import fit_line

    pair = read_nist_pair(data_path)
    constant = pair.constant_axis
    assert constant is not None
    assert pair.parameters["direction"][constant] == 0.0
    keep = [i for i in range(3) if i != constant]
    result = fit_line(pair.points[:, keep])
    reference = {"point": pair.parameters["point"][keep], "direction": pair.parameters["direction"][keep]}
    assert result.point.shape == (2,)
    assert_fit_close(result, reference, position_mm=TOLERANCE, angle_rad=TOLERANCE)


# --- reader errors -------------------------------------------------------------------


def _write(folder: Path, name: str, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("3\n1 2 3\n4 5 6\n", None),  # count says 3, two rows
        ("2\n1 2 3\n4 5\n", 3),
        ("2\n1 2 3\n4 x 6\n", 3),
        ("two\n1 2 3\n4 5 6\n", 1),
        ("2\n1 2 3\n4 nan 6\n", 3),
        ("", 1),
    ],
)
def test_malformed_data_file(tmp_path: Path, text: str, line: int | None) -> None:
    path = _write(tmp_path / "Sphere", "bad.ds", text)
    with pytest.raises(FileFormatError) as info:
        read_nist_points(path)
    assert info.value.path == str(path) and info.value.line == line


def test_malformed_fit_files(tmp_path: Path) -> None:
    folder = tmp_path / "Sphere"
    _write(folder, "s.ds", "4\n1 0 0\n-1 0 0\n0 1 0\n0 0 1\n")
    _write(folder, "s.fit", "0\n0\n0\n")
    with pytest.raises(FileFormatError, match="expected 4 values, got 3"):
        read_nist_pair(folder / "s.ds")
    fit = _write(folder, "t.fit", "0\n1 2\n")
    with pytest.raises(FileFormatError) as info:
        read_nist_fit(fit)
    assert info.value.line == 2
    cone = tmp_path / "Cone"
    _write(cone, "c.ds", "1\n0 0 0\n")
    _write(cone, "c.fit", "0\n0\n0\n0\n0\n1\n1\n180\n")
    with pytest.raises(FileFormatError, match="apex angle"):
        read_nist_pair(cone / "c.ds")
    _write(cone, "d.ds", "1\n0 0 0\n")
    _write(cone, "d.fit", "0\n0\n0\n0\n0\n2\n1\n30\n")
    with pytest.raises(FileFormatError, match="unit direction"):
        read_nist_pair(cone / "d.ds")


def test_unknown_folder_and_missing_fit(tmp_path: Path) -> None:
    path = _write(tmp_path / "Ellipse", "e.ds", "1\n0 0 0\n")
    with pytest.raises(InvalidInputError, match="folder 'Ellipse'"):
        read_nist_pair(path)
    lonely = _write(tmp_path / "Plane", "p.ds", "1\n0 0 0\n")
    with pytest.raises(FileNotFoundError):
        read_nist_pair(lonely)
    assert list(iter_nist_pairs(tmp_path)) == []
    with pytest.raises(FileNotFoundError):
        list(iter_nist_pairs(tmp_path / "missing"))
