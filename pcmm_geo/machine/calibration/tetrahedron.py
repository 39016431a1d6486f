"""Tetrahedron calibration from external-CMM probings (thesis ch. 7, eqs 7.1-7.5, Table 7.1).

The external CMM (CMM₁) probes each spherical joint of the tetrahedron at two or more
slider positions and the probe tip once (thesis 7.1); the lasers are read at every
slider position.  From these:

1. every joint and the tip get a Gaussian sphere fit (centre, radius, form);
2. each arm's **slider line** is the least-squares 3-D line through its joint centres
   (eq 7.1 for two positions; straightness reported for three or more);
3. the laser **scale and offset** of each arm come from regressing the joint position
   along its slider line on the laser reading (``s = scale * laser + offset``; position
   measured from the foot of the tip centre on the line, so ``offset`` ≈ 60 mm + d for
   a seed-like arm);
4. the **theoretical probe point** of eq 7.2 is the point nearest the three lines, in
   two variants: least squares over all three lines, and the seed's average of the three
   pairwise closest-point midpoints;  the **skew distances** between lines are reported;
5. the seed's parameters follow from the **probe-tip centre** ``P_0``: dead distance
   ``d_i = |P_i - P_0| - l_i - 60`` (eq 7.3, start of laser range 60 mm excluded), arm
   angle ``beta_in = acos(P_i.P_in / (|P_i| |P_in|))`` (eq 7.4 **corrected**, erratum 6;
   ``P`` relative to ``P_0``), each averaged over positions; and ``b_in`` (eq 7.5) as the
   minimum over a laser sweep of ``sqrt(L_i² + L_in² - 2 L_i L_in cos beta_in)`` with
   ``L = l + 60 + d``.

Because the seed's slider lines do not pass through the tip (erratum 9), the seed's
``d`` and ``beta`` depend on the slider position; :attr:`TetrahedronCalibration.tetrahedron`
gives the rigid-body model (:mod:`pcmm_geo.machine.kinematics.model`) that needs no such assumption.

Examples
--------
>>> from pcmm_geo.machine.calibration.seed import appendix_cd_files
>>> probings, lasers = appendix_cd_files()
>>> cal = calibrate_tetrahedron(probings, lasers)
>>> {arm: round(d, 2) for arm, d in cal.dead_distance.items()}
{'a': 314.48, 'b': 312.74, 'c': 309.42}
>>> {pair: round(b, 2) for pair, b in cal.beta_deg.items()}
{'ab': 68.25, 'bc': 69.03, 'ca': 68.7}
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import CalibrationError, InvalidInputError
from pcmm_geo.fit.skew import mean_pairwise_midpoint, nearest_point_to_lines, pairwise_closest_points
from pcmm_geo.machine.calibration.geometry import angle_between, fit_center_line, seed_printed_angle_deg
from pcmm_geo.machine.calibration.inputs import check_readings
from pcmm_geo.machine.calibration.probings import (
    ARMS,
    LaserTable,
    ProbedFeatures,
)
from pcmm_geo.machine.calibration.result import PAIRS, SliderLineCalibration, TetrahedronCalibration

if TYPE_CHECKING:
    from pcmm_geo.machine.calibration.datum import DatumFrame

#: the slider-line pairs a-b, b-c, c-a (:data:`PAIRS`) as indices into :data:`ARMS`
_PAIR_INDICES = ((0, 1), (1, 2), (2, 0))

__all__ = [
    "PAIRS",
    "SliderLineCalibration",
    "TetrahedronCalibration",
    "as_laser_table",
    "as_probed_features",
    "b_in_from_lasers",
    "calibrate_tetrahedron",
    "seed_printed_angle_deg",
]

FloatArray = NDArray[np.float64]
START_OF_RANGE = 60.0


# ---------------------------------------------------------------------------------------------- inputs
def as_probed_features(probings: ProbedFeatures | str | Path | Mapping[Any, Any]) -> ProbedFeatures:
    """The probings as :class:`ProbedFeatures`: one already, a CSV path (:meth:`ProbedFeatures.from_csv`) or arrays
    (:meth:`ProbedFeatures.from_points`).

    Raises
    ------
    InvalidInputError
        None of these.
    """
    if isinstance(probings, ProbedFeatures):
        return probings
    if isinstance(probings, (str, Path)):
        return ProbedFeatures.from_csv(probings)
    if isinstance(probings, Mapping):
        return ProbedFeatures.from_points(probings)
    raise InvalidInputError(
        "probings", "ProbedFeatures (from_csv, from_qif, from_points), a CSV path or a mapping of probed "
        "points", type(probings).__name__
    )


def as_laser_table(lasers: LaserTable | str | Path | ArrayLike | Mapping[int, ArrayLike],
                   positions: tuple[int, ...]) -> LaserTable:
    """The laser readings as :class:`LaserTable`: one already, a CSV path (:meth:`LaserTable.from_csv`), or readings
    (:meth:`LaserTable.from_readings`; an array is in the order of ``positions``)."""
    if isinstance(lasers, LaserTable):
        return lasers
    if isinstance(lasers, (str, Path)):
        return LaserTable.from_csv(lasers)
    return LaserTable.from_readings(lasers, None if isinstance(lasers, Mapping) else positions)


# ------------------------------------------------------------------------------------------ calculation
def b_in_from_lasers(
    lasers: ArrayLike,
    dead_distance: Mapping[str, float],
    beta_deg: Mapping[str, float],
    *,
    laser_start_of_range: float = START_OF_RANGE,
) -> tuple[dict[str, float], dict[str, int]]:
    """Eq 7.5: ``b_in = min over readings of sqrt(L_i² + L_in² - 2 L_i L_in cos beta_in)``.

    Parameters
    ----------
    lasers : array_like, shape (M, 3)
        Laser readings of a sweep (arms a, b, c, mm).
    dead_distance : mapping
        ``{'a', 'b', 'c'}`` dead distances (mm); ``L = laser + start_of_range + d``.
    beta_deg : mapping
        ``{'ab', 'bc', 'ca'}`` arm angles (degrees).
    laser_start_of_range : float
        60 mm for the seed's lasers.

    Returns
    -------
    b_in : dict
        ``{'ab', 'bc', 'ca'}`` minimum distance (mm).
    index : dict
        Row of the sweep giving each minimum.

    Examples
    --------
    >>> b, i = b_in_from_lasers([[40.0, 40.0, 40.0]], {"a": 0, "b": 0, "c": 0}, {"ab": 60, "bc": 60, "ca": 60})
    >>> round(b["ab"], 9), i["ab"]
    (100.0, 0)
    """
    readings = check_readings(lasers, None, "laser_sweep")
    lengths = readings + laser_start_of_range + np.array([dead_distance[arm] for arm in ARMS])
    b_values: dict[str, float] = {}
    index: dict[str, int] = {}
    for k, pair in enumerate(PAIRS):
        first, second = lengths[:, k], lengths[:, (k + 1) % 3]
        squared = first**2 + second**2 - 2.0 * first * second * np.cos(np.radians(beta_deg[pair]))
        row = int(np.argmin(squared))
        b_values[pair] = float(np.sqrt(max(squared[row], 0.0)))
        index[pair] = row
    return b_values, index


def _linear(x: FloatArray, y: FloatArray) -> tuple[float, float]:
    """Least-squares ``y = slope x + intercept`` (slope 0 when x does not vary)."""
    if np.ptp(x) == 0:
        return 0.0, float(np.mean(y))
    slope, intercept = np.polyfit(x, y, 1)
    return float(slope), float(intercept)


def _slider_line(
    arm: str, centres: FloatArray, readings: FloatArray, tip_center: FloatArray, fixed_scale: float | None
) -> SliderLineCalibration:
    fitted = fit_center_line(centres, what=arm)
    direction = fitted.direction
    if (centres.mean(axis=0) - tip_center) @ direction < 0:
        direction = -direction
    foot = fitted.point + ((tip_center - fitted.point) @ direction) * direction
    slide = (centres - foot) @ direction
    if fixed_scale is not None:
        scale = float(fixed_scale)
        offset = float(np.mean(slide - scale * readings))
    else:
        if np.ptp(readings) <= 1e-9 * max(1.0, float(np.abs(readings).max())):
            raise CalibrationError(
                f"arm {arm}: expected laser readings that change between slider positions, got {readings.tolist()}",
                arm=arm,
            )
        scale, offset = _linear(readings, slide)
    residuals = slide - (scale * readings + offset)
    return SliderLineCalibration(
        arm=arm,
        point=foot,
        direction=direction,
        straightness=fitted.straightness,
        laser_scale=float(scale),
        laser_offset=float(offset),
        slide=slide,
        laser_residuals=residuals,
        tip_offset=float(np.linalg.norm(tip_center - foot)),
    )


def _seed_values(
    centres: FloatArray, origin: FloatArray, readings: FloatArray, start: float
) -> tuple[dict[str, FloatArray], dict[str, FloatArray]]:
    """Per-position dead distances (eq 7.3) and angles (eq 7.4 corrected) seen from ``origin``."""
    arms_from_origin = centres - origin  # (K, 3, 3)
    lengths = np.linalg.norm(arms_from_origin, axis=-1)
    dead = {arm: lengths[:, k] - readings[:, k] - start for k, arm in enumerate(ARMS)}
    beta = {
        pair: angle_between(arms_from_origin[:, k], arms_from_origin[:, (k + 1) % 3])
        for k, pair in enumerate(PAIRS)
    }
    return dead, beta


def calibrate_tetrahedron(
    probings: ProbedFeatures | str | Path | Mapping[Any, Any],
    lasers: LaserTable | str | Path | ArrayLike | Mapping[int, ArrayLike],
    *,
    laser_start_of_range: float = START_OF_RANGE,
    laser_sweep: ArrayLike | None = None,
    laser_scale: float | None = None,
    datum_plane: ArrayLike | None = None,
    datum_hole: ArrayLike | None = None,
) -> TetrahedronCalibration:
    r"""Calibrate the tetrahedron from external-CMM probings (thesis ch. 7).

    Parameters
    ----------
    probings : ProbedFeatures
        The probed balls (mm, CMM₁ frame), made by :meth:`ProbedFeatures.from_csv` (raw
        ``feature,position,x,y,z`` or the seed's ``x,y,z,d,r`` export, see
        :mod:`pcmm_geo.machine.calibration.probings`), :meth:`ProbedFeatures.from_points`
        (``{"joint_a": [(N, 3) per position] or {position: (N, 3)}, ..., "tip": (N, 3)}``) or
        :meth:`ProbedFeatures.from_qif` (a QIF 3.0 results file; with what was refitted:
        :func:`~pcmm_geo.machine.calibration.qif_probings.read_qif_probings`, its ``.features``).
        A CSV path or such a mapping is still read with them (:func:`as_probed_features`).
    lasers : LaserTable
        Laser readings per slider position (mm, arms a, b, c), made by
        :meth:`LaserTable.from_csv` (``position,laser_a,laser_b,laser_c``) or
        :meth:`LaserTable.from_readings`; a CSV path, an array (K, 3) in sorted position order
        or ``{position: (3,)}`` is still read with them (:func:`as_laser_table`).
    laser_start_of_range : float
        Start of the laser measuring range excluded from the dead distance (60 mm, Table 7.1).
    laser_sweep : array_like, shape (M, 3), optional
        Laser readings recorded while the pivots travel their whole range (thesis 7.2);
        ``b_in`` is the minimum of eq 7.5 over it.  Default: the calibration readings.
    laser_scale : float, optional
        Fix the laser scale of every arm (e.g. 1.0) and fit only the offsets; by default
        scale and offset are both fitted (needs readings that differ between positions).
    datum_plane, datum_hole : array_like, shape (N, 3), optional
        Points probed on the tetrahedron's flat face and in its cylindrical hole (thesis
        7.1); when both are given every result is expressed in that datum frame (see
        :func:`pcmm_geo.machine.calibration.datum.datum_frame`).

    Returns
    -------
    TetrahedronCalibration

    Raises
    ------
    FileFormatError
        Malformed CSV (with path and line).
    CalibrationError
        Missing laser readings for a probed position, lasers that do not change (when the
        scale is fitted), joints probed at fewer than two positions.
    InvalidInputError
        Arrays of the wrong shape or type.
    DegenerateGeometryError
        Joint centres that coincide, parallel slider lines.

    See Also
    --------
    pcmm_geo.uncertainty.calibration.calibration_covariance : the covariance of the calibrated parameters
    pcmm_geo.machine.calibration.columns.calibrate_columns : the column lines (eqs 2.19-2.20)
    pcmm_geo.fit.skew.nearest_point_to_lines : the probe point nearest the slider lines (eq 7.2)

    Notes
    -----
    Thesis chapter 7 [1]_: each slider line is fitted through the probed joint centres
    (eq 7.1 takes two of them),

    .. math::

        \mathbf{r}_i(t) = \mathbf{P}_{i1} + t \, \mathbf{w}_i , \qquad i = a, b, c ,

    the theoretical probe point is the point nearest the three lines (eq 7.2 minimises the
    squared distance between pairs of lines; here the least-squares point of all three), and
    each arm's overall length is the laser reading plus the dead distance (eq 7.3, with the
    60 mm start of range, finding F10 of [2]_),

    .. math::

        L_i = l_i + 60\ \mathrm{mm} + d_i .

    The angle between arms uses the product of the lengths (eq 7.4 corrected, erratum 6 of
    [2]_),

    .. math::

        \beta_{in} = \cos^{-1} \frac{\mathbf{P}_i \cdot \mathbf{P}_{in}}
                                    {\lVert \mathbf{P}_i \rVert \, \lVert \mathbf{P}_{in} \rVert} ,

    and the pivot distance follows from the cosine rule (eq 7.5),
    :math:`b_{in}^2 = l_i^2 + l_{in}^2 - 2 l_i l_{in} \cos\beta_{in}`.  Because the slider lines
    do not meet at the tip the dead distance depends on the slider position (erratum 9); both
    the per-position values and their means are reported.

    References
    ----------
    .. [1] *A critical investigation into the accuracy of a parallel mechanism coordinate measuring machine*,
           MEng (Mechatronic) thesis, Faculty of Engineering, Stellenbosch University ("the thesis"; the copy
           the project works from names neither author nor year). Chapter 7, eqs 7.1-7.5; Table 7.1.
    .. [2] The project's errata of the thesis, :doc:`/errata` (numbered as there).

    Examples
    --------
    See the module docstring (Appendix C/D reproduction of Table 7.1).
    """
    features = as_probed_features(probings)
    positions = features.positions
    table = as_laser_table(lasers, positions)
    readings = table.at(positions)
    if not np.isfinite(laser_start_of_range):
        raise InvalidInputError("laser_start_of_range", "a finite length in mm", str(laser_start_of_range))
    if laser_scale is not None and not (np.isfinite(laser_scale) and laser_scale != 0):
        raise InvalidInputError("laser_scale", "a finite non-zero number or None", str(laser_scale))
    datum = None
    if (datum_plane is None) != (datum_hole is None):
        raise InvalidInputError("datum", "both datum_plane and datum_hole, or neither", "only one of them")
    if datum_plane is not None and datum_hole is not None:
        from pcmm_geo.machine.calibration.datum import datum_frame

        reference = np.mean([features.joints["a"][pos].center for pos in positions], axis=0)
        datum = datum_frame(datum_plane, datum_hole, x_towards=reference)
        features = datum.transform_features(features)
    sweep = readings if laser_sweep is None else check_readings(laser_sweep, None, "laser_sweep")
    return _calibrate(features, readings, sweep, laser_start_of_range, laser_scale, datum)


def _calibrate(
    features: ProbedFeatures,
    readings: FloatArray,
    sweep: FloatArray,
    start: float,
    fixed_scale: float | None,
    datum: DatumFrame | None,
) -> TetrahedronCalibration:
    positions = features.positions
    centres = features.centers()  # (K, 3, 3)
    tip_center = np.asarray(features.tip.center, dtype=float)
    lines = {
        arm: _slider_line(arm, centres[:, k], readings[:, k], tip_center, fixed_scale) for k, arm in enumerate(ARMS)
    }
    line_points = [lines[arm].point for arm in ARMS]
    line_dirs = [lines[arm].direction for arm in ARMS]
    probe_point = np.array(nearest_point_to_lines(line_points, line_dirs).point)
    probe_pairwise = mean_pairwise_midpoint(line_points, line_dirs, pairs=_PAIR_INDICES)
    line_pairs = pairwise_closest_points(line_points, line_dirs, pairs=_PAIR_INDICES)
    skew = {pair: float(line_pairs.distance[k]) for k, pair in enumerate(PAIRS)}
    dead_k, beta_k = _seed_values(centres, tip_center, readings, start)
    dead_t, beta_t = _seed_values(centres, probe_pairwise, readings, start)
    dead = {arm: float(np.mean(values)) for arm, values in dead_k.items()}
    beta = {pair: float(np.mean(values)) for pair, values in beta_k.items()}
    beta_deg = {pair: float(np.degrees(value)) for pair, value in beta.items()}
    b_in, b_index = b_in_from_lasers(sweep, dead, beta_deg, laser_start_of_range=start)
    return TetrahedronCalibration(
        positions=positions,
        lasers=readings,
        joint_spheres={arm: tuple(features.joints[arm][pos] for pos in positions) for arm in ARMS},
        tip=features.tip,
        tip_center=tip_center,
        slider_lines=lines,
        probe_point=probe_point,
        probe_point_pairwise=probe_pairwise,
        skew_distances=skew,
        dead_distance=dead,
        dead_distance_per_position=dead_k,
        dead_distance_linear={arm: _linear(readings[:, k], dead_k[arm]) for k, arm in enumerate(ARMS)},
        beta=beta,
        beta_per_position=beta_k,
        # Appendix C: beta_ca against laser a, beta_ab against laser b, beta_bc against laser c
        beta_linear={pair: _linear(readings[:, (k + 1) % 3], beta_k[pair]) for k, pair in enumerate(PAIRS)},
        dead_distance_from_probe_point=dead_t,
        beta_from_probe_point=beta_t,
        b_in=b_in,
        b_in_sweep_index=b_index,
        laser_start_of_range=float(start),
        sweep=sweep,
        datum=datum,
        source=features.source,
        fixed_laser_scale=fixed_scale,
    )
