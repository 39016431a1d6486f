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

The reading itself (roles, feature map, refit) is
:func:`~pcmm_geo.machine.calibration.inputs.read_qif_balls`, which
:meth:`ProbedFeatures.from_qif <pcmm_geo.machine.calibration.probings.ProbedFeatures.from_qif>`
shares; here are what ``pcmm calibrate`` reports of it (:class:`QifProbings`) and the writer.

Examples
--------
>>> role_of("JOINT_B_2"), role_of("tip"), role_of("datum A")
(('joint_b', 2), ('tip', None), None)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import fields
from pathlib import Path

import numpy as np

from pcmm_geo._records import record
from pcmm_geo.machine.calibration.geometry import FittedSphere
from pcmm_geo.machine.calibration.inputs import QifBalls, Role, read_feature_map, read_qif_balls, role_of
from pcmm_geo.machine.calibration.probings import ProbedFeatures, _assemble

__all__ = ["QifProbings", "read_feature_map", "read_qif_probings", "role_of", "write_qif_probings"]


@record(kw_only=True)
class QifProbings(QifBalls):
    """Probed calibration balls read from a QIF file: what was read of each ball, and the balls assembled.

    The attributes of :class:`~pcmm_geo.machine.calibration.inputs.QifBalls` (``roles``,
    ``refitted``, ``reported``, ``ignored``, ``notes``, the balls by role) and:

    Attributes
    ----------
    features : ProbedFeatures
        For :func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron`.
    """

    features: ProbedFeatures


def read_qif_probings(path: str | Path, *, feature_map: Mapping[str, Role] | str | Path | None = None,
                      max_bytes: int | None = None, spell_setting: Callable[..., str] | None = None) -> QifProbings:
    """Read the calibration probings (joint balls per slider position, tip ball) from a QIF results file.

    The balls are read by :func:`~pcmm_geo.machine.calibration.inputs.read_qif_balls` (the route
    of :meth:`ProbedFeatures.from_qif <pcmm_geo.machine.calibration.probings.ProbedFeatures.from_qif>`
    too) and assembled into probed features.

    Parameters
    ----------
    path, feature_map, max_bytes, spell_setting
        As :func:`~pcmm_geo.machine.calibration.inputs.read_qif_balls`: the QIF 3.0 results file,
        QIF feature name -> role (or a JSON file of it), the largest file read, how a size
        refusal names ``max_bytes``.

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
    balls = read_qif_balls(path, feature_map=feature_map, max_bytes=max_bytes, spell_setting=spell_setting)
    features = _assemble(balls.spheres, balls.points, balls.source)
    return QifProbings(**{field.name: getattr(balls, field.name) for field in fields(balls)},
                       features=features)


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
