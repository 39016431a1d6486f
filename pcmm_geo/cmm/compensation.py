"""Probe compensation decided once: what the caller states and what the file says, made one plan.

Every route that fits points a CMM measured -- the refit of ``pcmm qif verify``
(:func:`~pcmm_geo.cmm.refit.refit_feature`), the points of ``pcmm fit|form FILE``
(:mod:`pcmm_geo.cmm.points`) and the calibration balls of a QIF file
(:mod:`pcmm_geo.machine.calibration.qif_probings`) -- asks the same two questions, here:

1. **Radius** (:func:`plan_compensation`): are the points surface points or probe-ball centres,
   and of which radius?  The file's ``Compensated`` flag (for the set, or per point) and
   ``ProbeRadius`` / ``ProbeRadii``, and the caller's ``compensated`` and ``probe_radius``, give
   one :class:`CompensationPlan`: the points (compensated one by one along their normals where
   flags or radii differ from point to point), the one radius left to apply to the fitted element
   (ISO 10360-5 probing: the element fitted to probe centres is offset by the ball radius onto
   the touched surface; :func:`pcmm_geo.fit.probe.compensate_probe`), and where it came from.
   A statement that contradicts the file is refused.
2. **Side** (:func:`side_arguments`): on which side of a feature of size the material is --
   stated by the caller, the file's ``InternalExternal``, the point normals, or inferred from the
   nominal size (said so).

What was done is one record, :class:`Compensation`, whose :meth:`~Compensation.to_dict` is the JSON
``compensation`` object of every command.

Errors name the Python parameters (``compensated=False``); a caller that speaks otherwise passes
``spell_setting`` (:mod:`pcmm_geo.io.cmm.settings`; the command line spells ``--compensated no``).

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.io.cmm import MeasuredPointSet
>>> centres = MeasuredPointSet(id=1, points=np.zeros((3, 3)), compensated=False, probe_radius=1.5)
>>> plan = plan_compensation(centres)
>>> plan.radius, plan.radius_source
(1.5, 'probe centres (Compensated=false), ProbeRadius from the file')
>>> spell_value(python_setting, "compensated", False)
'False'
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.io.cmm import SpellSetting, python_setting

if TYPE_CHECKING:
    from pcmm_geo.fit.probe import ProbeCompensation
    from pcmm_geo.io.cmm import MeasuredPointSet

__all__ = ["Compensation", "CompensationPlan", "plan_compensation", "side_arguments", "spell_value"]

FloatArray = NDArray[np.float64]

#: the radius source of points the file flags as compensated
FILE_COMPENSATED = "the points are surface points (Compensated=true)"


def spell_value(spell_setting: SpellSetting, parameter: str, value: Any) -> str:
    """A value of ``parameter`` as the caller writes it: ``'internal'`` in Python, ``internal`` on the command line.

    Examples
    --------
    >>> spell_value(python_setting, "material_side", "internal")
    "'internal'"
    """
    name = spell_setting(parameter)
    spelled = spell_setting(parameter, value)
    return spelled[len(name):].lstrip("= ") if spelled.startswith(name) else spelled


@record
class Compensation:
    """How the probe radius was handled for one fitted element: the one record of every route.

    Attributes
    ----------
    probe_radius_mm : float
        Radius applied to the element (0 when none was).
    side : {"internal", "external", "none", "unknown"}
        Material side of a feature of size; planes, lines and points are touched from outside
        the material (``"external"``, direction in ``outward``); ``"none"``: nothing applied;
        ``"unknown"``: nothing states the side of this circle, cylinder or sphere: its centre
        and axis (independent of the side) are refitted, its diameter is not.
    inferred : bool
        The side was inferred from the nominal size (the file did not state it).
    source : str
        Where radius and side came from, in words.
    method : str
        ``"element offset"``, ``"points along normals"`` or ``"none"``.
    outward : ndarray (3,) or None
        Unit normal out of the material used for a plane, line or point.
    radius_source, side_source : str or None
        The two halves of ``source`` where they are kept apart.
    """

    probe_radius_mm: float
    side: str
    inferred: bool
    source: str
    method: str
    outward: FloatArray | None = None
    radius_source: str | None = None
    side_source: str | None = None

    @classmethod
    def from_probe(cls, result: ProbeCompensation, radius_source: str, side_source: str) -> Compensation:
        """The record of :func:`~pcmm_geo.fit.probe.compensate_probe`'s result."""
        return cls(float(result.probe_radius), str(result.side), bool(result.inferred),
                   f"{radius_source}; side {side_source}", result.method,
                   None if result.outward is None else np.asarray(result.outward, dtype=float),
                   radius_source, side_source)

    def to_dict(self) -> dict[str, Any]:
        """The JSON ``compensation`` object."""
        out: dict[str, Any] = {"probe_radius_mm": self.probe_radius_mm, "side": self.side, "inferred": self.inferred,
                               "method": self.method, "source": self.source}
        if self.radius_source is not None:
            out["radius_source"] = self.radius_source
        if self.side_source is not None:
            out["side_source"] = self.side_source
        if self.outward is not None:
            out["outward_normal"] = self.outward.tolist()
        return out

    def describe(self) -> str:
        """One line of text: radius, its source and the side."""
        side_source = self.side_source if self.side_source is not None else self.source
        radius_source = self.radius_source if self.radius_source is not None else self.source
        if self.outward is not None:
            where = f"outward normal from {side_source}"
        else:
            where = f"material side {self.side}" + (" (inferred)" if self.inferred else "") + f" from {side_source}"
        return (f"probe compensation: radius {self.probe_radius_mm:.6g} mm ({radius_source}), {where}; "
                "the element fitted to the probe centres is offset onto the surface")


@record
class CompensationPlan:
    """What is to be done with the probe radius of one set of points.

    Attributes
    ----------
    points : ndarray (N, 3)
        The points to fit: as read, or surface points where they were compensated one by one.
    normals : ndarray (N, 3) or None
        Their outward normals where known.
    radius : float
        Radius left to apply to the fitted element (mm; 0: the points are surface points).
    radius_source : str
        Where that came from, in words.
    point_radii : ndarray (N,) or None
        Radius applied to each point here (mm; None: none was).
    assumed : bool
        Nothing said whether the points are probe centres: surface points were assumed
        (``unstated="surface"``).
    """

    points: FloatArray
    normals: FloatArray | None
    radius: float
    radius_source: str
    point_radii: FloatArray | None = None
    assumed: bool = False

    def to_dict(self) -> dict[str, Any]:
        """``{"probe_radius_mm", "radius_source", "per_point", "assumed"}``."""
        return {"probe_radius_mm": self.radius, "radius_source": self.radius_source,
                "per_point": self.point_radii is not None, "assumed": self.assumed}


def plan_compensation(point_set: MeasuredPointSet, *, compensated: bool | None = None,
                      probe_radius: float | None = None, where: str = "the file",
                      unstated: Literal["refuse", "surface"] = "refuse", strict: bool = False,
                      spell_setting: SpellSetting = python_setting) -> CompensationPlan:
    """Decide the probe radius of a point set from the file's flags and the caller's statement.

    Parameters
    ----------
    point_set : MeasuredPointSet
        Points (mm) with what the file says: ``compensated`` (None: the format does not say),
        ``compensated_per_point``, ``probe_radius``, ``probe_radii``, ``normals``.
    compensated : bool, optional
        The caller's statement: the points are surface points (True) or probe centres (False).
    probe_radius : float, optional
        The caller's probe radius (mm); overrides the file's.
    where : str
        What the points are, for messages (``"the file"``, a file and feature).
    unstated : {"refuse", "surface"}
        Neither the file nor the caller says whether the points are probe centres: refuse
        (a CMM format that should say), or take them as surface points (plain point files; the
        plan is marked ``assumed``), probe centres of ``probe_radius`` when it is given.
    strict : bool
        Refuse a ``probe_radius`` (or ``compensated=False``) for points the file says are
        compensated; without it (a radius given for a whole document) such points keep theirs.
    spell_setting : callable
        How messages name ``compensated`` and ``probe_radius`` (:mod:`pcmm_geo.io.cmm.settings`).

    Returns
    -------
    CompensationPlan

    Raises
    ------
    InvalidInputError
        A statement that contradicts the file, probe centres without a radius, points to
        compensate one by one without normals or radii, nothing said where ``unstated="refuse"``;
        ``what`` is the parameter that would settle it.
    """
    spell = spell_setting
    if compensated not in (None, True, False):
        raise InvalidInputError(spell("compensated"), f"{spell_value(spell, 'compensated', True)} or "
                                f"{spell_value(spell, 'compensated', False)}", repr(compensated))
    if probe_radius is not None and not (np.isfinite(probe_radius) and probe_radius > 0):
        raise InvalidInputError(spell("probe_radius"), "a positive probe radius (mm)", repr(probe_radius))
    points = np.asarray(point_set.points, dtype=float)
    normals = None if point_set.normals is None else np.asarray(point_set.normals, dtype=float)
    said_no, radius_given = spell("compensated", False), spell("probe_radius")

    def refuse_contradiction() -> None:
        if strict and (compensated is False or probe_radius is not None):
            given = said_no if compensated is False else radius_given
            raise InvalidInputError(given, f"nothing: {where} says its points are already compensated "
                                    "(Compensated=true); the radius would be added twice", given)
        if compensated is False:
            raise InvalidInputError(spell("compensated"), f"nothing: {said_no} contradicts {where}, which says "
                                    "Compensated=true", spell_value(spell, "compensated", False))

    if point_set.compensated is True:
        refuse_contradiction()
        return CompensationPlan(points, normals, 0.0, FILE_COMPENSATED)
    if point_set.compensated_per_point is not None:
        refuse_contradiction()
        which = ~np.asarray(point_set.compensated_per_point, dtype=bool)
        radii = _point_radii(points, normals, point_set, which, "per-point Compensations differ", spell)
        return CompensationPlan(_along_normals(points, normals, radii), normals, 0.0,
                                "per-point compensation flags: probe centres compensated along their normals", radii)
    if point_set.compensated is None:
        if compensated is None:
            if unstated == "refuse":
                raise InvalidInputError(spell("compensated"), f"{spell_value(spell, 'compensated', True)} or "
                                        f"{spell_value(spell, 'compensated', False)}: {where} does not say whether "
                                        "its points are probe centres or surface points", "nothing")
            if probe_radius is None:
                return CompensationPlan(points, normals, 0.0, "surface points (no probe radius given)", assumed=True)
            return CompensationPlan(points, normals, float(probe_radius), f"probe centres, radius {radius_given}")
        if compensated:
            if strict and probe_radius is not None:
                raise InvalidInputError(radius_given, f"no radius with {spell('compensated', True)}",
                                        repr(probe_radius))
            return CompensationPlan(points, normals, 0.0, f"surface points ({spell('compensated', True)})")
        radius = probe_radius if probe_radius is not None else point_set.probe_radius
        if radius is None:
            raise InvalidInputError(radius_given, f"the probe radius of the probe centres ({said_no})", "none")
        return CompensationPlan(points, normals, float(radius), f"probe centres ({said_no}), radius " +
                                (radius_given if probe_radius is not None else "from the file"))
    if compensated is True:
        raise InvalidInputError(spell("compensated"), f"{spell_value(spell, 'compensated', False)}: {where} says its "
                                "points are probe centres (Compensated=false)", spell_value(spell, "compensated", True))
    if probe_radius is not None:
        return CompensationPlan(points, normals, float(probe_radius),
                                f"probe centres (Compensated=false), radius {radius_given}")
    if point_set.probe_radii is not None:
        radii = _point_radii(points, normals, point_set, np.ones(len(points), dtype=bool),
                             "per-point ProbeRadii differ", spell)
        return CompensationPlan(_along_normals(points, normals, radii), normals, 0.0,
                                "per-point ProbeRadii: probe centres compensated along their normals", radii)
    if point_set.probe_radius is None:
        raise InvalidInputError(radius_given, f"the probe radius: {where} holds probe centres (Compensated=false) "
                                "without a ProbeRadius", "none")
    return CompensationPlan(points, normals, float(point_set.probe_radius),
                            "probe centres (Compensated=false), ProbeRadius from the file")


def _point_radii(points: FloatArray, normals: FloatArray | None, point_set: MeasuredPointSet,
                 which: NDArray[np.bool_], why: str, spell: SpellSetting) -> FloatArray:
    if normals is None:
        raise InvalidInputError("normals", f"point normals to compensate the points one by one ({why})", "no normals")
    radii = point_set.probe_radii if point_set.probe_radii is not None else point_set.probe_radius
    if radii is None:
        raise InvalidInputError(spell("probe_radius"), f"a probe radius ({why}; the file gives none)", "none")
    radii = np.broadcast_to(np.asarray(radii, dtype=float), (len(points),))
    return np.where(which, radii, 0.0)


def _along_normals(points: FloatArray, normals: FloatArray | None, radii: FloatArray) -> FloatArray:
    from pcmm_geo.fit.probe import compensate_points

    return compensate_points(points, normals, radii)


def side_arguments(material_side: str | None, *, file_side: str | None = None, internal_external: str | None = None,
                   normals: FloatArray | None = None, points: FloatArray | None = None,
                   nominal_diameter: float | None = None, where: str = "the file", required: bool = True,
                   spell_setting: SpellSetting = python_setting) -> tuple[dict[str, Any], str]:
    """Keyword arguments of :func:`~pcmm_geo.fit.probe.compensate_probe` that fix the material side, and their source.

    In order: the caller's ``material_side`` (checked against the file and, by
    ``compensate_probe``, against the point normals), the file's ``InternalExternal``, the point
    normals, the nominal diameter (the side is then inferred).  Nothing tells the side: ``({}, "")``
    where not ``required``.

    Raises
    ------
    InvalidInputError
        A stated side the file contradicts; nothing tells the side and it is ``required``
        (``what`` names ``material_side``).
    """
    spell = spell_setting
    if material_side is not None:
        if file_side is not None and file_side != material_side:
            raise InvalidInputError(spell("material_side"), f"{spell_value(spell, 'material_side', file_side)} (or no "
                                    f"{spell('material_side')}): {where} says InternalExternal={internal_external}",
                                    spell_value(spell, "material_side", material_side))
        stated = spell("material_side")
        if normals is not None:  # compensate_probe checks the stated side against them
            return {"side": material_side, "points": points, "outward": normals}, stated
        return {"side": material_side}, stated
    if file_side is not None:
        return {"side": file_side}, "the file's InternalExternal"
    if normals is not None:
        return {"points": points, "outward": normals}, "the point normals"
    if nominal_diameter is not None:
        return {"nominal_diameter": nominal_diameter}, f"the nominal diameter {nominal_diameter:.6g} mm"
    if not required:
        return {}, ""
    raise InvalidInputError(spell("material_side"), f"internal or external: nothing in {where} tells on which side the "
                            f"material is (InternalExternal {internal_external or 'not stated'}, no point normals, no "
                            "nominal size)", "nothing")
