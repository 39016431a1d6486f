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

from pcmm_geo.errors import FileFormatError, InvalidInputError, OutputExistsError
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


def _sphere_from(data: Mapping[str, Any]) -> FittedSphere:
    radius = data.get("radius")
    form = data.get("form")
    return FittedSphere(
        center=np.array(data["centre"], dtype=float).reshape(3),
        radius=math.nan if radius is None else float(radius),
        form=math.nan if form is None else float(form),
        n_points=int(data.get("n_points", 0)),
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
    from pcmm_geo.io._text import read_json_file

    document = read_json_file(file)
    if not isinstance(document, dict):
        raise FileFormatError(str(file), f"expected a JSON object, got {type(document).__name__}")
    schema = document.get("schema")
    if not isinstance(schema, str) or not schema.startswith("pcmm_geo.machine.calibration/"):
        raise FileFormatError(str(file), f"expected schema {CALIBRATION_SCHEMA!r}, got {schema!r}")
    if schema != CALIBRATION_SCHEMA:
        raise FileFormatError(
            str(file), f"expected schema version {SCHEMA_VERSION} ({CALIBRATION_SCHEMA!r}), got {schema!r}"
        )
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
    try:
        inputs = document["inputs"]
        positions = tuple(int(p) for p in inputs["positions"])
        joints = {
            arm: {pos: _sphere_from(s) for pos, s in zip(positions, inputs["joint_spheres"][arm], strict=True)}
            for arm in ARMS
        }
        features = ProbedFeatures(joints=joints, tip=_sphere_from(inputs["tip"]), points={}, source=inputs["source"])
        lasers = np.array(inputs["lasers"], dtype=float).reshape(len(positions), 3)
        sweep = np.array(inputs["sweep"], dtype=float).reshape(-1, 3)
        datum = None
        if inputs.get("datum") is not None:
            from pcmm_geo.machine.calibration.datum import DatumFrame

            datum = DatumFrame.from_dict(inputs["datum"])
        scale = inputs.get("laser_scale")
        cal = _calibrate(
            features, lasers, sweep, float(inputs["laser_start_of_range"]), None if scale is None else float(scale),
            datum,
        )
        stored = document["results"]
        for key, values in (("dead_distance", cal.dead_distance), ("beta_deg", cal.beta_deg), ("b_in", cal.b_in)):
            for name, value in values.items():
                if abs(float(stored[key][name]) - value) > _AGREEMENT * max(1.0, abs(value)):
                    raise FileFormatError(
                        str(file), f"results.{key}.{name}: expected {value!r} (recomputed from inputs), "
                        f"got {stored[key][name]!r}; the file was edited or damaged"
                    )
    except FileFormatError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise FileFormatError(str(file), f"expected calibration inputs and results, got a problem: {exc!r}") from None
    return cal


def load_covariance(path: str | Path) -> dict[str, Any] | None:
    """The ``"covariance"`` entry of a calibration file (names, units, values, matrix), or None.

    Read it with :meth:`pcmm_geo.uncertainty.calibration.CalibrationCovariance.from_dict`.

    Raises
    ------
    FileFormatError
        Not a calibration file of a known schema version.
    """
    _, document = _read_document(path)
    entry = document.get("covariance")
    return dict(entry) if isinstance(entry, Mapping) else None


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
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine

    file, document = _read_document(path)
    if "machine" not in document:
        raise FileFormatError(str(file), "expected a 'machine' entry (saved with columns=...), got none")
    try:
        return RigidBodyMachine.from_dict(document["machine"])
    except InvalidInputError as exc:
        raise FileFormatError(str(file), f"machine: {exc}") from None
