"""Versioned calibration files (JSON) for the tetrahedron calibration and the rigid-body model.

A file holds

* ``schema`` -- :data:`CALIBRATION_SCHEMA` (``"pcmm_geo.machine.calibration/<version>"``);
* ``inputs`` -- everything :func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron` used
  (fitted joint and tip spheres, laser readings, sweep, options, datum frame), so loading
  recomputes the calibration exactly;
* ``results`` -- the calibrated values for people and other programs
  (:meth:`TetrahedronCalibration.summary`: ``dead_distance``, ``beta_deg``, ``b_in``, ...;
  angles in degrees under keys ending in ``_deg``, although ``TetrahedronCalibration.beta``
  is in radians since 0.2.0 -- the file format is unchanged);
  on loading they must agree with the recomputation, which catches edited or damaged files;
* ``tetrahedron`` -- the rigid-body tetrahedron in the layout of
  :meth:`RigidBodyMachine.to_dict` ``["tetrahedron"]``;
* ``machine`` -- optionally, a whole :meth:`RigidBodyMachine.to_dict` (when column lines are
  supplied), which :func:`load_machine` returns for the kinematics;
* ``covariance`` -- optionally, the calibrated parameters' covariance with their names
  (:meth:`pcmm_geo.uncertainty.calibration.CalibrationCovariance.to_dict`); files without
  it load as before and :func:`load_covariance` returns None for them;
* ``created`` (UTC, ISO 8601) and ``extra`` (free JSON-ready notes).

Files are never overwritten unless asked (``overwrite=True``); writes go through a
temporary file and an atomic rename.

Examples
--------
>>> import tempfile, pathlib
>>> from pcmm_geo.machine.calibration import calibrate_tetrahedron
>>> from pcmm_geo.machine.calibration.seed import appendix_cd_files
>>> cal = calibrate_tetrahedron(*appendix_cd_files())
>>> path = save_calibration(cal, pathlib.Path(tempfile.mkdtemp()) / "cal.json")
>>> round(load_calibration(path).dead_distance["a"], 2)
314.48
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.errors import FileFormatError, InvalidInputError, OutputExistsError, PcmmGeoError
from pcmm_geo.io.text import JsonNode
from pcmm_geo.machine.calibration.geometry import FittedSphere
from pcmm_geo.machine.calibration.probings import ARMS, ProbedFeatures

if TYPE_CHECKING:
    from pcmm_geo.machine.calibration.result import TetrahedronCalibration
    from pcmm_geo.machine.kinematics.model import ColumnLine, RigidBodyMachine

__all__ = [
    "CALIBRATION_SCHEMA",
    "SCHEMA_VERSION",
    "load_calibration",
    "load_covariance",
    "load_machine",
    "load_stored_machine",
    "machine_from_json",
    "save_calibration",
]

SCHEMA_VERSION = 1
CALIBRATION_SCHEMA = f"pcmm_geo.machine.calibration/{SCHEMA_VERSION}"
_AGREEMENT = 1e-8  # mm or degrees: stored results vs recomputation


def _finite_or_none(value: float) -> float | None:
    return None if not math.isfinite(value) else float(value)


def _sphere_dict(sphere: FittedSphere) -> dict[str, Any]:
    return {
        "centre": sphere.center.tolist(),
        "radius": _finite_or_none(sphere.radius),
        "form": _finite_or_none(sphere.form),
        "n_points": int(sphere.n_points),
    }


def _sphere_from(node: JsonNode) -> FittedSphere:
    node.object()
    n_points = node.get("n_points")
    return FittedSphere(
        center=node["centre"].vector(3),
        radius=node["radius"].number(low=0.0, allow_null=True),
        form=node["form"].number(low=0.0, allow_null=True),
        n_points=0 if n_points is None else n_points.integer(low=0),
    )


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def save_calibration(
    cal: TetrahedronCalibration,
    path: str | Path,
    *,
    overwrite: bool = False,
    columns: Mapping[str, ColumnLine] | None = None,
    extra: Mapping[str, Any] | None = None,
    covariance: Any = None,
) -> Path:
    """Write a calibration as versioned JSON.

    Parameters
    ----------
    cal : TetrahedronCalibration
    path : str or Path
        Target file (``.json``).
    overwrite : bool
        Replace an existing file; default False.
    columns : mapping, optional
        ``{'a', 'b', 'c'}`` -> :class:`~pcmm_geo.machine.kinematics.model.ColumnLine`; when given the
        file also holds the complete rigid-body machine (``"machine"``).
    extra : mapping, optional
        JSON-ready notes stored under ``"extra"``.
    covariance : CalibrationCovariance, optional
        Stored under ``"covariance"`` (its ``to_dict()``: names, units, values, matrix).

    Returns
    -------
    Path

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is false.
    InvalidInputError
        ``extra`` not JSON-serialisable, or ``columns`` not keyed by the arms.

    Examples
    --------
    See the module docstring.
    """
    from pcmm_geo._atomic import may_overwrite
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine

    target = Path(path)
    if target.exists() and not may_overwrite(target, overwrite):  # pcmm calibrate --overwrite-out counts too
        raise OutputExistsError(str(target))
    tetrahedron = cal.tetrahedron
    document: dict[str, Any] = {
        "schema": CALIBRATION_SCHEMA,
        "kind": "tetrahedron",
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "units": "mm; angles in degrees where the key ends in _deg",
        "inputs": {
            "source": cal.source,
            "positions": list(cal.positions),
            "lasers": cal.lasers.tolist(),
            "sweep": cal.sweep.tolist(),
            "laser_start_of_range": cal.laser_start_of_range,
            "laser_scale": cal.fixed_laser_scale,
            "joint_spheres": {arm: [_sphere_dict(s) for s in cal.joint_spheres[arm]] for arm in ARMS},
            "tip": _sphere_dict(cal.tip),
            "datum": None if cal.datum is None else cal.datum.to_dict(),
        },
        "results": cal.summary(),
        "tetrahedron": _tetrahedron_dict(tetrahedron),
        "extra": dict(extra or {}),
    }
    if covariance is not None:
        document["covariance"] = covariance.to_dict()
    if columns is not None:
        if set(columns) != set(ARMS):
            raise InvalidInputError("columns", "column lines for arms 'a', 'b', 'c'", f"keys {sorted(columns)}")
        document["machine"] = RigidBodyMachine(tetrahedron, {arm: columns[arm] for arm in ARMS}).to_dict()
    try:
        text = json.dumps(_jsonable(document), indent=2, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError("extra", "JSON-serialisable values", str(exc)) from None
    from pcmm_geo._atomic import write_atomic

    return write_atomic(target, text + "\n", overwrite=overwrite)  # whole or not at all; folders created


def _tetrahedron_dict(tetrahedron: Any) -> dict[str, Any]:
    return {
        "tip_centre": tetrahedron.tip_center.tolist(),
        "sliders": {
            arm: {
                "point": s.point.tolist(),
                "direction": s.direction.tolist(),
                "laser_scale": float(s.laser_scale),
                "laser_offset": float(s.laser_offset),
            }
            for arm, s in tetrahedron.sliders.items()
        },
    }


def _read_document(path: str | Path) -> tuple[Path, dict[str, Any]]:
    file = Path(path)
    from pcmm_geo.io.text import read_json_file

    document = read_json_file(file)
    if not isinstance(document, dict):
        raise JsonNode(document, str(file)).fail("a JSON object")
    schema = document.get("schema")
    if not isinstance(schema, str) or not schema.startswith("pcmm_geo.machine.calibration/"):
        raise JsonNode(schema, str(file), "schema").fail(repr(CALIBRATION_SCHEMA))
    if schema != CALIBRATION_SCHEMA:
        raise JsonNode(schema, str(file), "schema").fail(f"version {SCHEMA_VERSION} ({CALIBRATION_SCHEMA!r})")
    return file, document


def load_calibration(path: str | Path) -> TetrahedronCalibration:
    """Read a calibration file written by :func:`save_calibration` and recompute it.

    Returns
    -------
    TetrahedronCalibration

    Raises
    ------
    FileFormatError
        Not JSON, wrong or unknown schema version, missing or malformed entries, or stored
        results that disagree with the stored inputs (edited / damaged file).
    OSError
        File cannot be read.

    Examples
    --------
    See the module docstring.
    """
    from pcmm_geo.machine.calibration.tetrahedron import _calibrate

    file, document = _read_document(path)
    root = JsonNode(document, str(file))
    inputs = root["inputs"].object()
    positions = tuple(node.integer() for node in inputs["positions"].list())
    if len(set(positions)) != len(positions):
        raise inputs["positions"].fail("distinct slider positions")
    spheres = inputs["joint_spheres"].object()
    joints = {
        arm: {pos: _sphere_from(node) for pos, node in zip(positions, spheres[arm].list(len(positions)), strict=True)}
        for arm in ARMS
    }
    features = ProbedFeatures(joints=joints, tip=_sphere_from(inputs["tip"]), points={},
                              source=inputs["source"].string())
    lasers = inputs["lasers"].matrix(len(positions), 3)
    sweep = inputs["sweep"].matrix(None, 3)
    start_of_range = inputs["laser_start_of_range"].number()
    scale_node = inputs.get("laser_scale")
    scale = None if scale_node is None else scale_node.number()
    stored = root["results"].object()
    datum = None
    try:
        datum_node = inputs.get("datum")
        if datum_node is not None:
            from pcmm_geo.machine.calibration.datum import DatumFrame

            datum_node["rotation"].matrix(3, 3)
            datum_node["origin"].vector(3)
            for key in ("plane_form", "hole_radius"):
                if datum_node.get(key) is not None:
                    datum_node[key].number()
            datum = DatumFrame.from_dict(datum_node.value)
        cal = _calibrate(features, lasers, sweep, start_of_range, scale, datum)
    except FileFormatError:
        raise
    except (PcmmGeoError, ArithmeticError, ValueError) as exc:  # inputs that parse but do not calibrate
        raise FileFormatError(str(file), f"inputs: expected calibration inputs that calibrate, got: {exc}") from None
    for key, values in (("dead_distance", cal.dead_distance), ("beta_deg", cal.beta_deg), ("b_in", cal.b_in)):
        for name, value in values.items():
            got = stored[key][name].number()
            if abs(got - value) > _AGREEMENT * max(1.0, abs(value)):
                raise FileFormatError(
                    str(file), f"results.{key}.{name}: expected {value!r} (recomputed from inputs), "
                    f"got {got!r}; the file was edited or damaged"
                )
    return cal


def load_covariance(path: str | Path) -> dict[str, Any] | None:
    """The ``"covariance"`` entry of a calibration file (names, units, values, matrix), or None.

    Read it with :meth:`pcmm_geo.uncertainty.calibration.CalibrationCovariance.from_dict`.

    Raises
    ------
    FileFormatError
        Not a calibration file of a known schema version, or an entry of the wrong layout
        (the message names the JSON path, e.g. ``covariance.matrix[2]``).
    """
    file, document = _read_document(path)
    node = JsonNode(document, str(file)).get("covariance")
    if node is None:
        return None
    names = [name.string() for name in node["names"].list()]
    count = len(names)
    for value in node["values"].list(count):
        value.number(allow_null=True)
    for row in node["matrix"].list(count):
        for value in row.list(count):
            value.number(allow_null=True)
    node["method"].string()
    node["probing_sigma_mm"].number(low=0.0)
    node["laser_sigma_mm"].number(low=0.0)
    if node.get("n_trials") is not None:
        node["n_trials"].integer(low=0)
    return dict(node.value)


def load_stored_machine(path: str | Path) -> RigidBodyMachine | None:
    """The rigid-body machine stored in a calibration file, or None when the file stores none.

    Raises
    ------
    FileFormatError
        Not a calibration file, or a ``"machine"`` entry that is damaged (never silently
        replaced by a default).
    """
    file, document = _read_document(path)
    if "machine" not in document:
        return None
    return machine_from_json(JsonNode(document, str(file))["machine"])


def load_machine(path: str | Path) -> RigidBodyMachine:
    """The rigid-body machine stored in a calibration file (written with ``columns=``).

    Raises
    ------
    FileFormatError
        No ``"machine"`` entry, or one the model cannot read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pcmm_geo.machine.calibration import calibrate_tetrahedron
    >>> from pcmm_geo.machine.calibration.seed import appendix_cd_files
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> cal = calibrate_tetrahedron(*appendix_cd_files())
    >>> columns = RigidBodyMachine.from_dpkm().columns
    >>> path = save_calibration(cal, pathlib.Path(tempfile.mkdtemp()) / "cal.json", columns=columns)
    >>> machine = load_machine(path)
    >>> bool(np.allclose(machine.tetrahedron.tip_center, cal.tip_center))
    True
    """
    machine = load_stored_machine(path)
    if machine is None:
        raise FileFormatError(str(path), "expected a 'machine' entry (saved with columns=...), got none")
    return machine


def machine_from_json(node: JsonNode) -> RigidBodyMachine:
    """A :class:`RigidBodyMachine` from its :meth:`~RigidBodyMachine.to_dict` layout, every field checked.

    Parameters
    ----------
    node : JsonNode
        The machine object inside a JSON document (a model file or a calibration's ``machine``).

    Raises
    ------
    FileFormatError
        A missing or mistyped field, named by its JSON path (``machine.columns.b.direction:
        expected a list of 3 numbers, got a list of 2``), or values the model refuses
        (e.g. a zero direction).

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> layout = RigidBodyMachine.from_dpkm().to_dict()
    >>> layout["columns"]["b"]["direction"] = [0, 1]
    >>> try:
    ...     machine_from_json(JsonNode({"machine": layout}, "cal.json")["machine"])
    ... except FileFormatError as exc:
    ...     print(exc)
    cal.json: machine.columns.b.direction: expected a list of 3 numbers, got a list of 2
    """
    from pcmm_geo.machine.kinematics.model import MODEL_SCHEMA, RigidBodyMachine

    node.object()
    node["schema"].string((MODEL_SCHEMA,))
    tetrahedron = node["tetrahedron"]
    tetrahedron["tip_centre"].vector(3)
    for arm in ARMS:
        slider = tetrahedron["sliders"][arm]
        slider["point"].vector(3)
        slider["direction"].vector(3)
        slider["laser_scale"].number()
        slider["laser_offset"].number()
        column = node["columns"][arm]
        column["point"].vector(3)
        column["direction"].vector(3)
        if column.get("encoder_scale") is not None:
            column["encoder_scale"].number()
    for key in ("reference_lasers", "reference_heights"):
        if node.get(key) is not None:
            node[key].vector(3)
    try:
        return RigidBodyMachine.from_dict(node.value)
    except (PcmmGeoError, ArithmeticError, ValueError, TypeError, KeyError) as exc:
        where = f"{node.where}: " if node.where else ""
        raise FileFormatError(node.file, f"{where}expected a valid machine model, got: {exc}") from None
