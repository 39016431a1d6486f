"""External-CMM probings of the calibration balls from a QIF 3.0 results file (thesis ch. 7).

The external CMM that probes the joint balls and the tip ball (thesis 7.1) may hand its results
over as QIF instead of the CSV formats of :mod:`pcmm_geo.machine.calibration.probings`.  Every
sphere feature measurement of the file plays a role: the joint ball of arm ``a``, ``b`` or ``c``
at a slider position, or the probe tip.  Roles come from

* the **default naming**: ``joint_a_1`` ... ``joint_c_K`` and ``tip`` (case-insensitive; ``_``,
  ``-``, ``.`` or a space between the parts, or none: ``JOINT A 1``, ``joint-b.2``, ``jointc3``);
* or a **feature map** (``--feature-map map.json``): a JSON object from QIF feature names to
  roles, ``{"SPH_1": "joint_a:1", "SPH_2": "joint_b:1", ..., "PROBE": "tip"}``.  With a map, the
  named features must exist and be spheres; other features are ignored (and listed).

A sphere with measured points is refitted from them (Gaussian, in the document's common frame:
the same fit as the CSV route's raw probings) -- the probe radius moves no centre, so the centre
is the same whether or not the points are compensated; its radius is compensated onto the ball
(a ball is an external sphere) where the file gives the probe radius, as :mod:`pcmm_geo.cmm.compensation`
decides for every fit of a CMM's points.  A sphere without points
contributes the centre the CMM reported (and its diameter and form where given), and is listed as
such.

Examples
--------
>>> role_of("JOINT_B_2"), role_of("tip"), role_of("datum A")
(('joint_b', 2), ('tip', None), None)
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pcmm_geo.errors import FileFormatError, PcmmGeoError
from pcmm_geo.machine.calibration.geometry import FittedSphere, fit_probed_sphere
from pcmm_geo.machine.calibration.probings import ProbedFeatures, _assemble

__all__ = ["QifProbings", "read_feature_map", "read_qif_probings", "role_of", "write_qif_probings"]

Role = tuple[str, int | None]
_JOINT = re.compile(r"^joint[ _.\-]?([abc])[ _.\-]?(\d{1,6})$", re.IGNORECASE)
_ROLE = re.compile(r"^(joint_[abc]):(\d{1,6})$|^(tip)$")


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


@dataclass(frozen=True)
class QifProbings:
    """Probed calibration balls read from a QIF file.

    Attributes
    ----------
    features : ProbedFeatures
        For :func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron`.
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

    features: ProbedFeatures
    roles: Mapping[str, Role]
    refitted: tuple[str, ...]
    reported: tuple[str, ...]
    ignored: tuple[str, ...]
    notes: tuple[str, ...] = ()


def read_qif_probings(path: str | Path, *, feature_map: Mapping[str, Role] | str | Path | None = None,
                      max_bytes: int | None = None, spell_setting: Callable[..., str] | None = None) -> QifProbings:
    """Read the calibration probings (joint balls per slider position, tip ball) from a QIF results file.

    Parameters
    ----------
    path : str or Path
        QIF 3.0 results file with one sphere feature measurement per ball and position.
    feature_map : mapping or path, optional
        QIF feature name -> role (see the module docstring), or a JSON file of it; default:
        the default naming.
    max_bytes : int, optional
        Largest QIF file read (default :data:`~pcmm_geo.io.cmm.DEFAULT_MAX_BYTES`).
    spell_setting : callable, optional
        How a size refusal names ``max_bytes`` (:func:`~pcmm_geo.io.cmm.read_qif`).

    Returns
    -------
    QifProbings

    Raises
    ------
    FileFormatError
        A mapped feature missing or not a sphere, a role given twice, a sphere without points and
        without a reported centre, a group that cannot be fitted, the tip missing, arms probed at
        different positions (as the CSV route); QIF reading errors (QifError, UnsafeXmlError).
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
    features = _assemble(fitted, arrays, source)
    ignored = tuple(str(f.name) for f in spheres if str(f.name) not in chosen)
    return QifProbings(features, {name: role for name, (_, role) in chosen.items()}, tuple(refitted),
                       tuple(reported), ignored, tuple(notes))


def write_qif_probings(features: ProbedFeatures, path: str | Path, *, overwrite: bool = False,
                       probe_radius: float | None = None, linear_unit: str = "mm") -> Path:
    """Write probed calibration balls as a QIF results file under the default naming.

    Each ball becomes a sphere feature measurement ``joint_<arm>_<position>`` or ``tip`` with the
    centre (and diameter and form where known) as actuals, and its raw points, where the probings
    have them, as a measured point set -- surface points, or probe centres when ``probe_radius`` is
    given (then written ``Compensated=false`` with that ``ProbeRadius``).

    Parameters
    ----------
    features : ProbedFeatures
        E.g. from :func:`~pcmm_geo.machine.calibration.probings.read_probings`.
    path : str or Path
    overwrite : bool
    probe_radius : float, optional
        The raw points are probe centres of this radius (mm).
    linear_unit : {"mm", "inch"}

    Returns
    -------
    Path

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    """
    from pcmm_geo.io.cmm import FeatureGeometry, FeatureReport, MeasuredPointSet, results_document, write_qif

    balls: list[tuple[Role, FittedSphere]] = [((f"joint_{arm}", position), features.joints[arm][position])
                                              for position in features.positions for arm in ("a", "b", "c")]
    balls.append((("tip", None), features.tip))
    reports = []
    for (feature, position), sphere in balls:
        name = feature if position is None else f"{feature}_{position}"
        raw = features.points.get((feature, position))
        points = None if raw is None else MeasuredPointSet(
            id=0, points=np.asarray(raw, dtype=float), compensated=probe_radius is None, probe_radius=probe_radius)
        diameter = None if not math.isfinite(sphere.radius) else 2.0 * sphere.radius
        form = None if not math.isfinite(sphere.form) else float(sphere.form)
        actual = FeatureGeometry(location=np.asarray(sphere.center, dtype=float), diameter=diameter, form=form)
        reports.append(FeatureReport(type="sphere", name=name, actual=actual, points=points))
    document = results_document(reports, source=str(path))
    return write_qif(document, path, overwrite=overwrite, linear_unit=linear_unit)


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
