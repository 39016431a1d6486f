"""Calibration inputs before they become probed features: arrays by role, laser readings, a QIF file's balls.

:func:`points_by_role` puts probed points given per arm into the ``{(feature, position): (N, 3)}``
form of :meth:`~pcmm_geo.machine.calibration.probings.ProbedFeatures.from_points`;
:func:`check_readings` checks laser readings (:meth:`~pcmm_geo.machine.calibration.probings.\
LaserTable.from_readings`, the sweep of :func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron`);
:func:`read_qif_balls` reads the balls of a QIF results file by role (:func:`role_of`, a feature
map: :func:`read_feature_map`), refitted through :func:`~pcmm_geo.cmm.compensation.plan_compensation`
where the file has the points -- the one route of
:meth:`~pcmm_geo.machine.calibration.probings.ProbedFeatures.from_qif` and
:func:`~pcmm_geo.machine.calibration.qif_probings.read_qif_probings` (``pcmm calibrate``).  It
returns plain data so that this module stays below the probed-features class that consumes it.

Examples
--------
>>> sorted(points_by_role({"joint_a": [[[0.0, 0, 0]]], "tip": [[1.0, 0, 0]]}))
[('joint_a', 1), ('tip', None)]
>>> role_of("JOINT_B_2"), role_of("tip"), role_of("datum A")
(('joint_b', 2), ('tip', None), None)
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import FileFormatError, InvalidInputError, PcmmGeoError
from pcmm_geo.machine.calibration.geometry import FittedSphere, fit_probed_sphere

__all__ = ["QifBalls", "check_readings", "points_by_role", "read_feature_map", "read_qif_balls", "role_of"]

Role = tuple[str, int | None]
_JOINT = re.compile(r"^joint[ _.\-]?([abc])[ _.\-]?(\d{1,6})$", re.IGNORECASE)
_ROLE = re.compile(r"^(joint_[abc]):(\d{1,6})$|^(tip)$")



def points_by_role(probings: Mapping[Any, Any]) -> dict[tuple[str, int | None], Any]:
    """Probed points by arm: ``{"joint_a": [(N, 3) per position] or {position: (N, 3)}, ..., "tip": (N, 3)}``
    as ``{(feature, position): (N, 3)}``.

    Raises
    ------
    InvalidInputError
        A key that is none of ``joint_a``, ``joint_b``, ``joint_c``, ``tip`` or a tuple.
    """
    points: dict[tuple[str, int | None], Any] = {}
    for key, value in probings.items():
        if isinstance(key, tuple):
            points[key] = value
        elif key == "tip":
            points[("tip", None)] = value
        elif key in ("joint_a", "joint_b", "joint_c"):
            items = value.items() if isinstance(value, Mapping) else enumerate(value, start=1)
            for position, pts in items:
                points[(key, int(position))] = pts
        else:
            raise InvalidInputError(
                "probings", "keys 'joint_a', 'joint_b', 'joint_c', 'tip' or (feature, position)", repr(key)
            )
    return points


def check_readings(value: Any, count: int | None, name: str) -> NDArray[np.float64]:
    """Laser readings as a finite (K, 3) array (``count`` rows when given).

    Raises
    ------
    InvalidInputError
        Another shape, NaN or inf; ``what`` is ``name``.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(name, "laser readings of shape (K, 3)", type(value).__name__) from None
    if arr.ndim != 2 or arr.shape[1] != 3 or (count is not None and arr.shape[0] != count):
        want = f"({count}, 3)" if count is not None else "(M, 3)"
        raise InvalidInputError(name, f"laser readings of shape {want} (arms a, b, c)", f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, "finite laser readings", "NaN or inf")
    return arr


def role_of(name: str | None) -> Role | None:
    """Role of a QIF feature name under the default naming, or None.

    Examples
    --------
    >>> role_of("joint-c.12")
    ('joint_c', 12)
    """
    if name is None:
        return None
    text = name.strip()
    if text.lower() == "tip":
        return ("tip", None)
    match = _JOINT.match(text)
    return None if match is None else (f"joint_{match.group(1).lower()}", int(match.group(2)))


def read_feature_map(path: str | Path) -> dict[str, Role]:
    """Read a feature map: a JSON object from QIF feature names to roles ``joint_a:1`` or ``tip``.

    Raises
    ------
    FileFormatError
        Not JSON, not an object, a role that is not ``joint_a|joint_b|joint_c:POSITION`` or
        ``tip``, two names given one role.
    """
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
        raw = json.loads(text)
    except UnicodeDecodeError:
        raise FileFormatError(str(file), "expected a UTF-8 JSON object, got undecodable bytes") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(str(file), f"expected a JSON object, got invalid JSON ({exc.msg})", exc.lineno) from None
    if not isinstance(raw, dict) or not raw:
        raise FileFormatError(str(file), "expected a JSON object {\"QIF feature name\": \"joint_a:1\" | \"tip\", ...}, "
                              f"got {type(raw).__name__}")
    roles: dict[str, Role] = {}
    seen: dict[Role, str] = {}
    for name, value in raw.items():
        match = _ROLE.match(value.strip()) if isinstance(value, str) else None
        if match is None:
            raise FileFormatError(str(file), f"feature {name!r}: expected a role 'joint_a:1' (joint_a, joint_b, "
                                  f"joint_c and a slider position) or 'tip', got {json.dumps(value)[:80]}")
        role: Role = ("tip", None) if match.group(3) else (match.group(1), int(match.group(2)))
        if role in seen:
            raise FileFormatError(str(file), f"role {_text(role)} given to both {seen[role]!r} and {name!r}")
        seen[role] = name
        roles[name] = role
    return roles


def _text(role: Role) -> str:
    return role[0] if role[1] is None else f"{role[0]} position {role[1]}"


@record
class QifBalls:
    """The calibration balls of a QIF file by role, before they are assembled into probed features.

    Attributes
    ----------
    spheres : dict
        ``(feature, position)`` -> :class:`~pcmm_geo.machine.calibration.geometry.FittedSphere`
        (position ``None`` for the tip); centre and radius in mm, the radius of the ball.
    points : dict
        ``(feature, position)`` -> measured points ``(N, 3)`` (mm) of the refitted balls.
    source : str
        The file.
    roles : dict
        QIF feature name -> ``(feature, position)`` used.
    refitted : tuple of str
        Names whose centre was refitted from measured points.
    reported : tuple of str
        Names whose centre is the one the CMM reported (no points in the file).
    ignored : tuple of str
        Sphere features of the file that play no role.
    notes : tuple of str
        Compensation and frame remarks.
    """

    spheres: Mapping[Role, FittedSphere]
    points: Mapping[Role, NDArray[np.float64]]
    source: str
    roles: Mapping[str, Role]
    refitted: tuple[str, ...]
    reported: tuple[str, ...]
    ignored: tuple[str, ...]
    notes: tuple[str, ...] = ()


def read_qif_balls(path: str | Path, *, feature_map: Mapping[str, Role] | str | Path | None = None,
                   max_bytes: int | None = None, spell_setting: Callable[..., str] | None = None) -> QifBalls:
    """Read the calibration balls (joint balls per slider position, tip ball) of a QIF results file, by role.

    The one route from QIF to the calibration: :meth:`~pcmm_geo.machine.calibration.probings.\
ProbedFeatures.from_qif` assembles its result into probed features,
    :func:`~pcmm_geo.machine.calibration.qif_probings.read_qif_probings` (``pcmm calibrate``) also
    reports what was refitted, reported and ignored.

    Parameters
    ----------
    path : str or Path
        QIF 3.0 results file with one sphere feature measurement per ball and position.
    feature_map : mapping or path, optional
        QIF feature name -> role (see :mod:`~pcmm_geo.machine.calibration.qif_probings`), or a JSON
        file of it; default: the default naming (:func:`role_of`).
    max_bytes : int, optional
        Largest QIF file read (default :data:`~pcmm_geo.io.cmm.DEFAULT_MAX_BYTES`).
    spell_setting : callable, optional
        How a size refusal names ``max_bytes`` (:func:`~pcmm_geo.io.cmm.read_qif`).

    Returns
    -------
    QifBalls

    Raises
    ------
    FileFormatError
        A mapped feature missing or not a sphere, a role given twice, a sphere without points and
        without a reported centre, a group that cannot be fitted, no sphere of the default naming;
        QIF reading errors (QifError, UnsafeXmlError).
    """
    from pcmm_geo.io.cmm import DEFAULT_MAX_BYTES, python_setting, read_qif

    source = str(path)
    document = read_qif(path, max_bytes=DEFAULT_MAX_BYTES if max_bytes is None else max_bytes,
                        spell_setting=spell_setting or python_setting)
    roles = read_feature_map(feature_map) if isinstance(feature_map, (str, Path)) else feature_map
    spheres = [f for f in document.measured_features if f.type == "sphere"]
    chosen: dict[str, Any] = {}
    if roles is not None:
        by_name = {f.name: f for f in document.measured_features if f.name is not None}
        for name, role in roles.items():
            feature = by_name.get(name)
            if feature is None:
                raise FileFormatError(source, f"the feature map names {name!r} ({_text(role)}), which the file does "
                                      "not hold")
            if feature.type != "sphere":
                raise FileFormatError(source, f"feature {name!r} ({_text(role)}) is a {feature.type}, not a sphere")
            chosen[name] = (feature, role)
    else:
        taken: dict[Role, str] = {}
        for feature in spheres:
            role = role_of(feature.name)
            if role is None:
                continue
            if role in taken:
                raise FileFormatError(source, f"features {taken[role]!r} and {feature.name!r} both name "
                                      f"{_text(role)}")
            taken[role] = str(feature.name)
            chosen[str(feature.name)] = (feature, role)
        if not chosen:
            names = ", ".join(repr(f.name) for f in spheres[:10]) or "none"
            raise FileFormatError(source, "expected sphere features named joint_a_1 ... joint_c_K and tip (or a "
                                  f"--feature-map), got sphere features {names}")
    fitted: dict[Role, FittedSphere] = {}
    arrays: dict[Role, Any] = {}
    refitted, reported, notes = [], [], []
    for name, (feature, role) in chosen.items():
        try:
            points = document.points_of(feature, frame="common")
        except PcmmGeoError as exc:
            raise FileFormatError(source, f"feature {name!r}: {exc}") from None
        if points is not None and len(points) > 0:
            surface, probe_radius, note = _ball_points(points, name)
            try:
                sphere = fit_probed_sphere(surface, what=f"{name} ({_text(role)})")
            except (PcmmGeoError, ValueError) as exc:
                raise FileFormatError(source, f"feature {name!r}: cannot fit a sphere: {exc}") from None
            radius = sphere.radius - probe_radius  # a ball is an external sphere: surface inside the centres
            if note:
                notes.append(f"{name}: {note}")
            fitted[role] = FittedSphere(sphere.center, radius, sphere.form, sphere.n_points)
            arrays[role] = np.asarray(points.points, dtype=float)
            refitted.append(name)
            continue
        actual = feature.actual
        if actual.location is None:
            raise FileFormatError(source, f"feature {name!r} ({_text(role)}) has neither measured points nor a "
                                  "reported centre")
        diameter = math.nan if actual.diameter is None else float(actual.diameter)
        form = math.nan if actual.form is None else float(actual.form)
        fitted[role] = FittedSphere(np.asarray(actual.location, dtype=float), 0.5 * diameter, form, 0)
        reported.append(name)
    ignored = tuple(str(f.name) for f in spheres if str(f.name) not in chosen)
    return QifBalls(fitted, arrays, source, {name: role for name, (_, role) in chosen.items()}, tuple(refitted),
                    tuple(reported), ignored, tuple(notes))


def _ball_points(points: Any, name: str) -> tuple[Any, float, str]:
    """The points to fit a ball to, the probe radius left to subtract from its radius (mm) and a note.

    Decided by :func:`~pcmm_geo.cmm.compensation.plan_compensation` like every other fit of a CMM's
    points (per-point flags or radii: compensated one by one along the point normals).  Where the
    file does not tell the probe radius, the ball is fitted to the points as they are: the centre
    is the same either way, only the radius is that of the probe centres.
    """
    from pcmm_geo.cmm.compensation import plan_compensation
    from pcmm_geo.errors import InvalidInputError

    try:
        plan = plan_compensation(points, where=f"feature {name!r}", unstated="surface")
    except InvalidInputError as exc:
        return points.points, 0.0, (f"radius of the probe centres ({exc}); the centre is the same either way")
    if plan.radius > 0:
        return plan.points, plan.radius, f"ball radius compensated by the probe radius {plan.radius:g} mm " \
            "(external sphere)"
    if plan.assumed:
        return plan.points, 0.0, "radius of the probe centres (the file gives no compensation or probe radius); " \
            "the centre is the same either way"
    if plan.point_radii is not None:
        return plan.points, 0.0, f"{plan.radius_source} before the ball was fitted"
    return plan.points, 0.0, ""
