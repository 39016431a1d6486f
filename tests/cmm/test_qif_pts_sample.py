"""The second opinion on the public QIF_PTS_SAMPLE.QIF (qif-community, Boost licence).

The sample holds three 219-point circles and an 18-point cylinder as probe centres
(``Compensated=false``, ``ProbeRadius 2.49978271104``), with the diameters the CMM reported.
Refitted from the points and compensated, every one agrees with the CMM's diameter within 2e-5 mm;
so it does after the whole file is moved by a rigid motion, and after the point sets are stored
in another frame with a QIF transform; surface points (``Compensated=true``) get no radius added.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.cmm import verify_document, verify_qif
from pcmm_geo.fit import compensate_probe, fit_circle, fit_cylinder
from pcmm_geo.fit.reference import random_rotation
from pcmm_geo.io.cmm import read_qif

SAMPLE = Path(__file__).parents[1] / "data" / "qif" / "samples" / "QIF_PTS_SAMPLE.QIF"
NS = "{http://qifstandards.org/xsd/qif3}"
PROBE_RADIUS = 2.49978271104
ROUND = {28: "circle", 261: "circle", 509: "circle", 796: "cylinder"}


def _checks(verification: object) -> dict[int, object]:
    return {check.id: check for check in verification.features}  # type: ignore[attr-defined]


def test_every_circle_and_cylinder_agrees_with_the_reported_diameter() -> None:
    checks = _checks(verify_qif(SAMPLE))
    for feature_id, kind in ROUND.items():
        check = checks[feature_id]
        assert check.type == kind and check.agrees is True, check.reason
        assert abs(check.difference["diameter_mm"]) < 2e-5
        assert check.compensation.probe_radius_mm == PROBE_RADIUS and check.compensation.side == "internal"
        # the refit diameter is the centres' plus twice the probe radius: the hole is bigger than its centres
        assert check.refit["diameter_mm"] == pytest.approx(check.reported["diameter_mm"], abs=2e-5)
    # InternalExternal INTERNAL is read; NOT_APPLICABLE is inferred from the nominal size and said so
    assert [checks[i].compensation.inferred for i in (28, 261, 509, 796)] == [True, False, False, True]
    assert checks[796].n_points == 18 and checks[261].n_points == 219
    # the CMM projected its circles onto their nominal (working) plane: compared within that plane
    assert "nominal plane" in checks[261].reason and "direction_angle_rad" not in checks[261].compared
    assert checks[796].compared == ("diameter_mm", "location_distance_mm", "direction_angle_rad")
    assert checks[796].difference["location_distance_mm"] < 1e-8


def test_findings_on_the_other_features() -> None:
    checks = _checks(verify_qif(SAMPLE))
    # single-point features: the reported location is the uncompensated probe centre
    for point in (756, 766, 786, 833):
        assert checks[point].agrees is False
        assert checks[point].difference["location_distance_mm"] == pytest.approx(PROBE_RADIUS, abs=1e-9)
        assert "probe centre" in checks[point].reason
    # a line whose only normal is its direction cannot be compensated; features without points are listed
    assert checks[255].agrees is None and "parallel to the line" in checks[255].reason
    assert checks[776].agrees is None and checks[776].n_points == 0
    assert checks[828].agrees is None and "PointFeatureMeasurement" in checks[828].reason


def test_circle_in_the_reported_plane_reproduces_the_cmm_to_nanometres() -> None:
    checks = _checks(verify_qif(SAMPLE, circle_plane="reported", tolerance_mm=1e-8))
    for feature_id in (28, 261, 509):
        assert checks[feature_id].agrees is True, checks[feature_id].reason
        assert abs(checks[feature_id].difference["diameter_mm"]) < 1e-8
        assert checks[feature_id].circle_plane == "reported"


def _numbers(text: str) -> np.ndarray:
    return np.array(text.split(), dtype=float)


def _point_text(node: object) -> np.ndarray:
    """The numbers of a <Points> element, whose text may be broken by comments; the comments are dropped."""
    from lxml import etree

    parts = [node.text or ""]  # type: ignore[attr-defined]
    for child in list(node):  # type: ignore[call-overload]
        if isinstance(child, etree._Comment):
            parts.append(child.tail or "")
            node.remove(child)  # type: ignore[attr-defined]
    return _numbers(" ".join(parts)).reshape(-1, 3)


def _write(values: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in values.ravel())


def _moved_sample(tmp_path: Path, rotation: np.ndarray, translation: np.ndarray) -> Path:
    from lxml import etree

    tree = etree.parse(str(SAMPLE))
    for node in tree.iter(f"{NS}Points"):
        node.text = _write(_point_text(node) @ rotation.T + translation)
    for tag in ("Location", "AxisPoint"):
        for node in tree.iter(f"{NS}{tag}"):
            if node.getparent().tag.endswith(("FeatureMeasurement", "FeatureNominal", "Axis")):
                node.text = _write(rotation @ _numbers(node.text) + translation)
    for tag in ("Normal", "Direction"):
        for node in tree.iter(f"{NS}{tag}"):
            if node.getparent().tag.endswith(("FeatureMeasurement", "FeatureNominal", "Axis")):
                node.text = _write(rotation @ _numbers(node.text))
    moved = tmp_path / "moved.qif"
    tree.write(str(moved))
    return moved


def test_the_same_after_a_rigid_motion_of_the_whole_file(tmp_path: Path) -> None:
    rotation = random_rotation(np.random.default_rng(20), 3)
    translation = np.array([412.5, -87.25, 1033.0])
    original = _checks(verify_qif(SAMPLE))
    moved = _checks(verify_qif(_moved_sample(tmp_path, rotation, translation)))
    assert set(moved) == set(original)
    for feature_id, check in moved.items():
        assert check.agrees == original[feature_id].agrees, (feature_id, check.reason)
    for feature_id in ROUND:
        assert abs(moved[feature_id].difference["diameter_mm"]) < 2e-5
        assert moved[feature_id].refit["diameter_mm"] == pytest.approx(original[feature_id].refit["diameter_mm"],
                                                                       abs=1e-9)
        assert moved[feature_id].difference["location_distance_mm"] == pytest.approx(
            original[feature_id].difference["location_distance_mm"], abs=1e-9)


def test_points_stored_in_another_frame_are_brought_into_the_common_frame(tmp_path: Path) -> None:
    """Point sets written in a part frame with a QIF Transform (TranformId) refit as in the common frame."""
    from lxml import etree

    rotation = random_rotation(np.random.default_rng(7), 3)
    translation = np.array([-250.0, 40.0, 310.0])
    tree = etree.parse(str(SAMPLE))
    root = tree.getroot()
    transforms = etree.Element(f"{NS}Transforms", n="1")
    transform = etree.SubElement(transforms, f"{NS}Transform", id="9001")
    rotation_node = etree.SubElement(transform, f"{NS}Rotation")
    for column, tag in enumerate(("XDirection", "YDirection", "ZDirection")):
        etree.SubElement(rotation_node, f"{NS}{tag}").text = _write(rotation[:, column])
    etree.SubElement(transform, f"{NS}Origin").text = _write(translation)
    root.insert(list(root).index(root.find(f"{NS}Features")), transforms)
    for point_set in root.iter(f"{NS}MeasuredPointSet"):
        points = point_set.find(f"{NS}Points")
        # stored = R^T (X - t): the transform maps them back into the common frame
        points.text = _write((_point_text(points) - translation) @ rotation)
        reference = etree.Element(f"{NS}TranformId")
        reference.text = "9001"
        point_set.insert(0, reference)
    stored = tmp_path / "stored_frame.qif"
    tree.write(str(stored))
    checks = _checks(verify_qif(stored))
    for feature_id in ROUND:
        assert checks[feature_id].agrees is True, checks[feature_id].reason
        assert abs(checks[feature_id].difference["diameter_mm"]) < 2e-5


def test_surface_points_get_no_radius_added_again(tmp_path: Path) -> None:
    from lxml import etree

    document = read_qif(SAMPLE)
    tree = etree.parse(str(SAMPLE))
    sets = {int(node.get("id")): node for node in tree.iter(f"{NS}MeasuredPointSet")}
    for feature_id, kind in ROUND.items():
        feature = document.feature(feature_id)
        centres = np.asarray(document.points_of(feature).points)
        fit = fit_circle(centres, method="projected") if kind == "circle" else fit_cylinder(centres)
        surface = compensate_probe(fit, PROBE_RADIUS, side="internal").surface_points(centres)
        node = sets[feature.point_set_refs[0].point_set_id]
        points = node.find(f"{NS}Points")
        _point_text(points)
        points.text = _write(surface)
        node.find(f"{NS}Compensated").text = "true"
    compensated = tmp_path / "compensated.qif"
    tree.write(str(compensated))
    checks = _checks(verify_qif(compensated))
    for feature_id in ROUND:
        check = checks[feature_id]
        assert check.agrees is True, check.reason
        assert check.compensation.side == "none" and check.compensation.probe_radius_mm == 0.0
        assert abs(check.difference["diameter_mm"]) < 2e-5
    # and centres wrongly flagged as surface points are caught: the diameter is short by 2 r
    tree = etree.parse(str(SAMPLE))
    for node in tree.iter(f"{NS}Compensated"):
        node.text = "true"
    flagged = tmp_path / "flagged.qif"
    tree.write(str(flagged))
    checks = _checks(verify_document(read_qif(flagged)))
    assert checks[261].agrees is False
    assert checks[261].difference["diameter_mm"] == pytest.approx(-2 * PROBE_RADIUS, abs=2e-5)
