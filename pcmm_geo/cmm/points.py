"""The points of one feature of a CMM file, ready for a fit, with what is known of their compensation.

``pcmm fit``/``pcmm form`` read point files of three kinds:

* a QIF results document (``.qif``): the points of one measured feature (chosen by QIF id or
  name when the file holds several), in the document's common frame, with the file's
  ``Compensated`` flag, ``ProbeRadius``, point normals, ``InternalExternal`` and nominal size;
* a PC-DMIS ``XYZIJK`` export (recognised by its first line): points with normals, no
  compensation flag;
* plain point files (CSV, XYZ, PLY, ...): points only.

:func:`probe_radius_to_apply` decides from the file and the caller's ``compensated`` /
``probe_radius`` whether a radius is still to be applied; a format that does not say whether its
points are probe centres (PC-DMIS, DMIS) is refused unless the caller says so.
:func:`compensate_fit` then offsets the fitted element (:func:`pcmm_geo.fit.probe.compensate_probe`)
with the material side from ``material_side``, the file's ``InternalExternal``, the point normals
or the nominal size (reported as inferred).  Both decisions are those of
:mod:`pcmm_geo.cmm.compensation`, as for the refit of ``pcmm qif verify``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.cmm.compensation import Compensation, plan_compensation, side_arguments
from pcmm_geo.elements import SPECS, Element
from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.io.cmm import SpellSetting, python_setting

if TYPE_CHECKING:
    from pcmm_geo.cmm.export import FileFeature
    from pcmm_geo.fit import FitResult
    from pcmm_geo.fit.probe import ProbeCompensation
    from pcmm_geo.io.cmm import CmmDocument, MeasuredFeature

__all__ = ["Compensation", "FeaturePoints", "compensate_fit", "load_feature_points", "probe_radius_to_apply",
           "side_before_fit"]

FloatArray = NDArray[np.float64]
#: formats whose points carry no compensation flag: the user must say
UNFLAGGED_FORMATS = ("pcdmis", "dmis")


@record
class FeaturePoints:
    """Points of one feature from a file, and what the file says about them.

    Attributes
    ----------
    points : ndarray (N, 3)
        mm, in the file's common frame (per-point compensations already applied where the file's
        flags or radii differ from point to point).
    normals : ndarray (N, 3) or None
        Outward surface normals where the file gives them.
    compensated : bool or None
        The file's flag; None when the format does not say.
    probe_radius : float or None
        The file's probe radius (mm).
    format : str
        ``"qif"``, ``"pcdmis"`` or ``"points"``.
    source : str
    feature : MeasuredFeature or None
        The QIF feature measurement the points belong to.
    material_side : str or None
        ``"internal"`` / ``"external"`` from the file's ``InternalExternal``.
    nominal_diameter : float or None
        Nominal diameter of the feature (mm), to infer the side.
    reported_normal : ndarray (3,) or None
        A normal the file reports for the feature (plane, point, line), out of the material.
    file_feature : FileFeature or None
        What the QIF file states about the feature that a refit written as QIF keeps (name,
        nominal, ``InternalExternal``, size tolerance; :func:`~pcmm_geo.cmm.export.file_feature`).
    """

    points: FloatArray
    format: str
    source: str
    normals: FloatArray | None = None
    compensated: bool | None = None
    probe_radius: float | None = None
    feature: MeasuredFeature | None = None
    material_side: str | None = None
    nominal_diameter: float | None = None
    reported_normal: FloatArray | None = None
    file_feature: FileFeature | None = None

    def describe(self) -> str:
        """One line: which feature of which file."""
        if self.feature is None:
            return self.source
        return f"{self.source} feature {self.feature.id} ({self.feature.name or 'unnamed'}, {self.feature.type})"


def load_feature_points(path: str | Path, *, element: Element | None = None, feature: str | None = None,
                        decimal: str | None = None, max_bytes: int | None = None,
                        spell_setting: SpellSetting = python_setting) -> FeaturePoints:
    """Read the points of one feature from a QIF document, a PC-DMIS XYZIJK export or a point file.

    Parameters
    ----------
    path : str or Path
    element : str, optional
        The element about to be fitted; a QIF file with several features with points is narrowed
        to those of that type.
    feature : str, optional
        QIF id (digits) or name of the feature measurement; needed when the choice is not unique.
    decimal : {".", ","}, optional
        Decimal mark of a text point file.
    max_bytes : int, optional
        Largest QIF file read (default :data:`~pcmm_geo.io.cmm.DEFAULT_MAX_BYTES`).
    spell_setting : callable
        How a size refusal names ``max_bytes`` (:mod:`pcmm_geo.io.cmm.settings`).

    Returns
    -------
    FeaturePoints

    Raises
    ------
    QifError, UnsafeXmlError, FileFormatError
        From the readers; a QIF file without points, a DMIS output or CALYPSO table (no points),
        or several candidates and no ``feature`` (the candidates are listed).
    InvalidInputError
        ``feature`` given for a file that is not QIF.
    """
    from pcmm_geo.cmm.files import detect_format
    from pcmm_geo.io.text import refuse_irregular

    file = Path(path)
    refuse_irregular(file)  # a FIFO would block the reader forever
    kind = detect_format(file)
    if kind == "qif":
        from pcmm_geo.io.cmm import DEFAULT_MAX_BYTES, read_qif

        document = read_qif(file, max_bytes=DEFAULT_MAX_BYTES if max_bytes is None else max_bytes,
                            spell_setting=spell_setting)
        return _from_document(document, element=element, feature=feature, spell_setting=spell_setting)
    if kind in ("dmis", "calypso"):
        raise FileFormatError(str(file), f"expected measured points, got a {kind.upper()} results file (feature "
                              "actuals and characteristics, no points): see pcmm qif show")
    if feature is not None:
        raise InvalidInputError(spell_setting("feature"), "a QIF file to choose a feature from", str(file))
    if kind == "pcdmis":
        from pcmm_geo.io.cmm import read_pcdmis_xyzijk

        point_set = read_pcdmis_xyzijk(file)
        return FeaturePoints(np.asarray(point_set.points, dtype=float), "pcdmis", str(file),
                             normals=None if point_set.normals is None else np.asarray(point_set.normals, dtype=float),
                             compensated=point_set.compensated, probe_radius=point_set.probe_radius)
    from pcmm_geo.io.points import read_points

    return FeaturePoints(read_points(file, decimal=decimal), "points", str(file))


def _choose(document: CmmDocument, element: Element | None, key: str | None,
            spell_setting: SpellSetting) -> MeasuredFeature:
    features = document.measured_features
    if key is not None:
        return document.feature(int(key) if key.strip().isdigit() else key)
    with_points = [f for f in features if f.point_set_refs]
    if not with_points:
        raise FileFormatError(document.source, "expected measured point sets, got a document without any")
    candidates = [f for f in with_points if element is None or f.type == element] or with_points
    if len(candidates) == 1:
        return candidates[0]
    listed = ", ".join(f"{f.id} {f.name or '(unnamed)'} ({f.type}, {len(f.point_set_refs)} point list(s))"
                       for f in candidates[:20])
    more = f" and {len(candidates) - 20} more" if len(candidates) > 20 else ""
    raise InvalidInputError(spell_setting("feature"), "the QIF id or name of one of the features with points: "
                            f"{listed}{more}", "none")


def _from_document(document: CmmDocument, *, element: Element | None, feature: str | None,
                   spell_setting: SpellSetting) -> FeaturePoints:
    from pcmm_geo.cmm.export import file_feature
    from pcmm_geo.cmm.refit import _context

    chosen = _choose(document, element, feature, spell_setting)
    point_set = document.points_of(chosen, frame="common")
    if point_set is None or len(point_set) == 0:
        raise FileFormatError(document.source, f"feature {chosen.id} ({chosen.name}) has no measured points")
    compensated, radius = point_set.compensated, point_set.probe_radius
    points = np.asarray(point_set.points, dtype=float)
    normals = None if point_set.normals is None else np.asarray(point_set.normals, dtype=float)
    if point_set.compensated_per_point is not None or (compensated is False and point_set.probe_radii is not None):
        try:  # flags or radii that differ from point to point: compensated here, one by one
            plan = plan_compensation(point_set, where=f"feature {chosen.id}", spell_setting=spell_setting)
            points, normals = plan.points, plan.normals
        except InvalidInputError as exc:
            raise FileFormatError(document.source, f"feature {chosen.id}: {exc}") from None
        compensated, radius = True, None
    context = _context(document, chosen)
    reported = context.actual.normal if context.actual.normal is not None else \
        (None if context.nominal is None else context.nominal.normal)
    return FeaturePoints(points, "qif", document.source, normals=normals, compensated=compensated,
                         probe_radius=radius, feature=chosen, material_side=context.side,
                         nominal_diameter=context.nominal_diameter,
                         reported_normal=None if reported is None else np.asarray(reported, dtype=float),
                         file_feature=file_feature(document, chosen))


def probe_radius_to_apply(data: FeaturePoints, *, compensated: bool | str | None = None,
                          probe_radius: float | None = None,
                          spell_setting: SpellSetting = python_setting) -> tuple[float, str]:
    """The probe radius still to apply (0: the points are surface points) and why.

    :func:`~pcmm_geo.cmm.compensation.plan_compensation` on the file's flags: plain point files
    are surface points unless a radius is given; formats without a flag need ``compensated``.

    Parameters
    ----------
    data : FeaturePoints
    compensated : bool, optional
        The caller's statement: surface points (True) or probe centres (False); required for
        formats without a flag.  ``"yes"`` / ``"no"`` are read as True / False.
    probe_radius : float, optional
        The caller's probe radius (mm).
    spell_setting : callable
        How messages name ``compensated`` and ``probe_radius`` (:mod:`pcmm_geo.io.cmm.settings`).

    Raises
    ------
    InvalidInputError
        A format without a compensation flag and no ``compensated``; a statement or radius
        that contradicts the file; probe centres without a radius.
    """
    from pcmm_geo.io.cmm import MeasuredPointSet

    if isinstance(compensated, str):
        if compensated not in ("yes", "no"):
            raise InvalidInputError(spell_setting("compensated"), "yes or no", repr(compensated))
        compensated = compensated == "yes"
    point_set = MeasuredPointSet(id=None, points=data.points, compensated=data.compensated,
                                 probe_radius=data.probe_radius)
    unflagged = data.format in UNFLAGGED_FORMATS
    where = f"{data.describe()} ({data.format} format)" if unflagged else data.describe()
    plan = plan_compensation(point_set, compensated=compensated, probe_radius=probe_radius, where=where,
                             unstated="refuse" if unflagged else "surface", strict=True, spell_setting=spell_setting)
    return plan.radius, plan.radius_source


def _side_kwargs(data: FeaturePoints, material_side: str | None, spell_setting: SpellSetting,
                 element: Element | None = None) -> tuple[dict[str, Any], str]:
    """The material side (:func:`~pcmm_geo.cmm.compensation.side_arguments`); required with ``element``."""
    return side_arguments(material_side, file_side=data.material_side,
                          internal_external=None if data.feature is None else data.feature.internal_external,
                          normals=data.normals, points=data.points, nominal_diameter=data.nominal_diameter,
                          where=data.describe(),
                          required=element is not None, spell_setting=spell_setting)


def side_before_fit(data: FeaturePoints, element: Element, radius: float, material_side: str | None,
                    fit: Any, *, spell_setting: SpellSetting = python_setting) -> str:
    """Material side of a feature of size, known before a fixed-radius fit (``fit(points)`` is a free fit).

    Raises
    ------
    InvalidInputError
        Nothing tells the side.
    """
    kwargs, _ = _side_kwargs(data, material_side, spell_setting, element)
    if "side" in kwargs and "outward" not in kwargs:
        return str(kwargs["side"])
    return _compensate(fit(data.points), radius, kwargs, data, spell_setting).side


def compensate_fit(fit: FitResult, element: Element, data: FeaturePoints, radius: float, *,
                   material_side: str | None = None, radius_source: str = "",
                   spell_setting: SpellSetting = python_setting) -> tuple[ProbeCompensation, Compensation]:
    """Offset a fit of probe centres onto the surface; returns the compensation and its record.

    Parameters
    ----------
    fit : FitResult
        The element fitted to the probe centres.
    element : str
    data : FeaturePoints
    radius : float
        Probe radius (mm), from :func:`probe_radius_to_apply`.
    material_side : {"internal", "external"}, optional
    radius_source : str
        Where ``radius`` came from (the second value of :func:`probe_radius_to_apply`).
    spell_setting : callable
        How messages name ``material_side`` and ``probe_radius``.

    Returns
    -------
    ProbeCompensation, Compensation
        The offset element, and the record (:meth:`Compensation.to_dict` is the JSON object).

    Raises
    ------
    InvalidInputError
        No way to tell the material side (or, for a plane / line, the outward normal); an
        element without an offset surface (torus).
    """
    from pcmm_geo.fit.probe import compensate_probe

    if SPECS[element].offset == "normal":  # plane, line
        if material_side is not None:
            raise InvalidInputError(spell_setting("material_side"), f"nothing for a {element}: its side is the "
                                    "surface normal (point normals or the file's reported normal)", material_side)
        outward = data.normals if data.normals is not None else data.reported_normal
        if outward is None:
            raise InvalidInputError("outward normal", f"point normals (XYZIJK, QIF Normals) or a reported normal to "
                                    f"compensate the {element} of {data.describe()}", "none")
        source = "the point normals" if data.normals is not None else "the file's reported normal"
        result = compensate_probe(fit, radius, outward=outward)
        return result, Compensation.from_probe(result, radius_source, source)
    if SPECS[element].offset not in ("radial", "conical"):  # no offset surface of its own
        raise InvalidInputError(spell_setting("probe_radius"), "an element with an offset surface (line, plane, "
                                "circle, sphere, cylinder, cone)", element)
    kwargs, source = _side_kwargs(data, material_side, spell_setting, element)
    result = _compensate(fit, radius, kwargs, data, spell_setting)
    return result, Compensation.from_probe(result, radius_source, source)


def _compensate(fit: FitResult, radius: float, kwargs: dict[str, Any], data: FeaturePoints,
                spell_setting: SpellSetting) -> ProbeCompensation:
    """:func:`~pcmm_geo.fit.probe.compensate_probe`; a stated side the point normals contradict names the parameter."""
    from pcmm_geo.fit.probe import compensate_probe

    try:
        return compensate_probe(fit, radius, **kwargs)
    except InvalidInputError as exc:
        if exc.what != "side" or "outward" not in kwargs:
            raise
        stated = kwargs["side"]
        shown = "internal" if stated == "external" else "external"  # the only other side
        name = spell_setting("material_side")
        raise InvalidInputError(name, f"{shown} (or no {name}): the point normals of {data.describe()} show an "
                                f"{shown} feature", stated) from None
