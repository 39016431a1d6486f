"""Typed calibration inputs: ProbedFeatures.from_csv / from_qif / from_points (read_qif_probings), LaserTable.from_*."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.machine.calibration import calibrate_tetrahedron
from pcmm_geo.machine.calibration.probings import LaserTable, ProbedFeatures, write_probings_csv
from pcmm_geo.machine.calibration.qif_probings import read_qif_probings, write_qif_probings
from pcmm_geo.machine.calibration.seed import appendix_cd_files

CENTRE = np.array([1.0, 2.0, 3.0])
DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)


def _ball(centre: np.ndarray, radius: float) -> np.ndarray:
    return centre + radius * DIRECTIONS


def _arrays() -> dict[str, object]:
    """Balls of radius 6.35 (joints) and 1 (tip) on exact points: six poles each."""
    joints = {f"joint_{arm}": {position: _ball(CENTRE + np.array([10.0 * k, 5.0 * position, 0.0]), 6.35)
                               for position in (1, 2)} for k, arm in enumerate("abc")}
    return {**joints, "tip": _ball(CENTRE, 1.0)}


def test_from_points_fits_the_balls_exactly() -> None:
    features = ProbedFeatures.from_points(_arrays())
    assert features.positions == (1, 2)
    np.testing.assert_allclose(features.joints["c"][2].center, CENTRE + np.array([20.0, 10.0, 0.0]), atol=1e-12)
    assert features.joints["b"][1].radius == pytest.approx(6.35, abs=1e-12)
    assert features.tip.radius == pytest.approx(1.0, abs=1e-12)
    with pytest.raises(InvalidInputError, match="joint_d"):
        ProbedFeatures.from_points({"joint_d": [_ball(CENTRE, 1.0)]})


def test_from_csv_and_the_qif_route_give_the_same_balls(tmp_path: Path) -> None:
    points = {("tip", None): _ball(CENTRE, 1.0)}
    points.update({(f"joint_{arm}", position): _ball(CENTRE + np.array([10.0 * k, 5.0 * position, 0.0]), 6.35)
                   for k, arm in enumerate("abc") for position in (1, 2)})
    csv = write_probings_csv(tmp_path / "probings.csv", points)
    from_csv = ProbedFeatures.from_csv(csv)
    qif = write_qif_probings(from_csv, tmp_path / "probings.qif", probe_radius=0.5)
    from_qif = read_qif_probings(qif).features
    for arm in "abc":
        for position in (1, 2):
            np.testing.assert_allclose(from_qif.joints[arm][position].center, from_csv.joints[arm][position].center,
                                       atol=1e-9)
            # the QIF file says its points are probe centres of radius 0.5: the ball is 0.5 smaller
            assert from_qif.joints[arm][position].radius == pytest.approx(6.35 - 0.5, abs=1e-9)
    # the typed constructor takes the same route: the balls built on CENTRE, to the fit's accuracy
    typed = ProbedFeatures.from_qif(qif)
    assert typed.positions == (1, 2) and typed.source == str(qif)
    for k, arm in enumerate("abc"):
        for position in (1, 2):
            np.testing.assert_allclose(typed.joints[arm][position].center,
                                       CENTRE + np.array([10.0 * k, 5.0 * position, 0.0]), atol=1e-9)
            assert typed.joints[arm][position].radius == pytest.approx(6.35 - 0.5, abs=1e-9)
    np.testing.assert_allclose(typed.tip.center, CENTRE, atol=1e-9)
    assert typed.tip.radius == pytest.approx(1.0 - 0.5, abs=1e-9)
    assert sorted(typed.points) == sorted(from_csv.points)


def test_from_qif_names_the_file_and_feature_it_refuses(tmp_path: Path) -> None:
    qif = write_qif_probings(ProbedFeatures.from_points(_arrays()), tmp_path / "balls.qif")
    with pytest.raises(FileFormatError, match=r"balls\.qif.*'SPH_9' \(tip\), which the file does not hold"):
        ProbedFeatures.from_qif(qif, feature_map={"SPH_9": ("tip", None)})
    mapped = ProbedFeatures.from_qif(qif, feature_map={"tip": ("tip", None), **{
        f"joint_{arm}_{position}": (f"joint_{arm}", position) for arm in "abc" for position in (1, 2)}})
    assert mapped.tip.radius == pytest.approx(1.0, abs=1e-9)  # points on the ball's surface: no probe radius


def test_laser_tables_from_readings() -> None:
    table = LaserTable.from_readings([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    assert table.positions == (1, 2) and table.at((2,)).tolist() == [[4.0, 5.0, 6.0]]
    mapped = LaserTable.from_readings({3: [1.0, 2.0, 3.0], 7: [4.0, 5.0, 6.0]})
    assert mapped.positions == (3, 7)
    assert LaserTable.from_readings([[1.0, 2.0, 3.0]], positions=(4,)).positions == (4,)
    with pytest.raises(InvalidInputError, match=r"shape \(2, 3\)"):
        LaserTable.from_readings([[1.0, 2.0, 3.0]], positions=(1, 2))
    with pytest.raises(InvalidInputError, match="finite"):
        LaserTable.from_readings([[1.0, np.nan, 3.0]])


def test_typed_inputs_calibrate_as_the_paths_do() -> None:
    probings, lasers = appendix_cd_files()
    by_path = calibrate_tetrahedron(probings, lasers)
    typed = calibrate_tetrahedron(ProbedFeatures.from_csv(probings), LaserTable.from_csv(lasers))
    for pair, beta in by_path.beta_deg.items():
        assert typed.beta_deg[pair] == pytest.approx(beta, abs=1e-12)
    for arm, d in by_path.dead_distance.items():
        assert typed.dead_distance[arm] == pytest.approx(d, abs=1e-12)
    with pytest.raises(InvalidInputError, match="from_csv, from_qif, from_points"):
        calibrate_tetrahedron(42, lasers)  # type: ignore[arg-type]
