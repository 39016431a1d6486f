"""Result types of the tetrahedron calibration (thesis ch. 7): slider lines and the whole calibration.

Produced by :func:`pcmm_geo.machine.calibration.calibrate_tetrahedron`; see that module for the
method.  Lengths in mm; angles in degrees where the name or docstring says so.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_fields, warn_deprecated
from pcmm_geo._records import record
from pcmm_geo.machine.calibration.geometry import FittedSphere
from pcmm_geo.machine.calibration.probings import ARMS

if TYPE_CHECKING:
    from pcmm_geo.machine.calibration.datum import DatumFrame
    from pcmm_geo.machine.kinematics.model import SliderLine, Tetrahedron

__all__ = ["PAIRS", "SliderLineCalibration", "TetrahedronCalibration"]

FloatArray = NDArray[np.float64]
#: arm pairs (i, in) in the seed's order: in = next arm clockwise
PAIRS: tuple[str, str, str] = ("ab", "bc", "ca")


@record
class SliderLineCalibration:
    """One arm's calibrated slider line (CMM₁ or datum frame).

    Attributes
    ----------
    arm : str
    point : ndarray, shape (3,)
        Foot of the perpendicular from the tip centre onto the line (mm); ``s = 0`` there.
    direction : ndarray, shape (3,)
        Unit vector from the tip side towards the joint.
    straightness : float
        Diameter of the cylinder about the line that holds all joint centres (mm); 0 for
        two positions.
    laser_scale, laser_offset : float
        ``s = laser_scale * laser + laser_offset`` (mm), least squares over positions.
    slide : ndarray, shape (K,)
        Joint-centre position along the line at each slider position (mm).
    laser_residuals : ndarray, shape (K,)
        ``slide - (laser_scale * laser + laser_offset)`` (mm); zero for two positions.
    tip_offset : float
        Distance of the tip centre from this line (mm); 0 when the line meets the tip.
    """

    arm: str
    point: FloatArray
    direction: FloatArray
    straightness: float
    laser_scale: float
    laser_offset: float
    slide: FloatArray
    laser_residuals: FloatArray
    tip_offset: float

    def joint(self, laser: ArrayLike) -> FloatArray:
        """Joint centre ``(..., 3)`` for laser readings ``(...,)`` (mm)."""
        slide = self.laser_scale * np.asarray(laser, dtype=float) + self.laser_offset
        return self.point + slide[..., None] * self.direction

    def to_model(self) -> SliderLine:
        """The rigid-body model's :class:`~pcmm_geo.machine.kinematics.model.SliderLine`."""
        from pcmm_geo.machine.kinematics.model import SliderLine

        return SliderLine(self.point, self.direction, float(self.laser_scale), float(self.laser_offset))


@renamed_fields(tip_centre="tip_center", joint_centres="joint_centers")
@record
class TetrahedronCalibration:
    """Result of :func:`calibrate_tetrahedron` (lengths mm, angles rad; degrees only where a name ends in ``_deg``).

    Attributes
    ----------
    positions : tuple of int
        Slider position indices, in the order of every per-position array.
    lasers : ndarray, shape (K, 3)
        Laser readings at those positions, arms a, b, c (mm).
    joint_spheres : dict
        ``{arm: (FittedSphere, ...)}`` per position.
    tip : FittedSphere
        Probe-tip sphere; ``tip_center`` is its centre.
    tip_center : ndarray, shape (3,)
    slider_lines : dict
        ``{arm: SliderLineCalibration}``.
    probe_point : ndarray, shape (3,)
        Eq 7.2: least-squares point nearest to the three slider lines.
    probe_point_pairwise : ndarray, shape (3,)
        The seed's variant: mean of the pairwise closest-point midpoints.
    skew_distances : dict
        ``{'ab', 'bc', 'ca'}``: shortest distance between the two slider lines (mm).
    dead_distance : dict
        ``{'a', 'b', 'c'}``: eq 7.3 from the tip centre, mean over positions (mm, the
        60 mm start of laser range excluded).
    dead_distance_per_position : dict
        ``{arm: (K,)}``.
    dead_distance_linear : dict
        ``{arm: (slope, intercept)}`` of ``d = slope * laser + intercept`` (Appendix C's
        "variable dead distance", least squares; slope unitless, intercept mm).
    beta : dict
        ``{'ab', 'bc', 'ca'}``: eq 7.4 (corrected) between arms i and in, seen from the tip
        centre, mean over positions, **radians** (the API contract; :attr:`beta_deg` in degrees).
    beta_per_position : dict
        ``{pair: (K,)}`` radians.
    beta_linear : dict
        ``{pair: (slope, intercept)}`` of ``beta = slope * laser_i + intercept`` (slope rad/mm,
        intercept rad; Appendix C regresses beta_ca on laser a, beta_ab on laser b, beta_bc on
        laser c).
    dead_distance_from_probe_point, beta_from_probe_point : dict
        The same per-position values computed from :attr:`probe_point_pairwise` (the seed's
        theoretical probe, Appendix D's ``D2`` and Beta rows 4-5), ``{key: (K,)}`` (mm, rad).
    b_in : dict
        ``{'ab', 'bc', 'ca'}``: eq 7.5, minimum over the laser sweep (mm).
    b_in_sweep_index : dict
        Index of the sweep row giving that minimum.
    laser_start_of_range : float
    sweep : ndarray, shape (M, 3)
        Laser readings used for ``b_in`` (the calibration readings when no sweep was given).
    datum : DatumFrame or None
        Datum frame applied to all coordinates (thesis 7.1) or None (CMM₁ frame).
    source : str
        Where the probings came from.
    """

    positions: tuple[int, ...]
    lasers: FloatArray
    joint_spheres: Mapping[str, tuple[FittedSphere, ...]]
    tip: FittedSphere
    tip_center: FloatArray
    slider_lines: Mapping[str, SliderLineCalibration]
    probe_point: FloatArray
    probe_point_pairwise: FloatArray
    skew_distances: Mapping[str, float]
    dead_distance: Mapping[str, float]
    dead_distance_per_position: Mapping[str, FloatArray]
    dead_distance_linear: Mapping[str, tuple[float, float]]
    beta: Mapping[str, float]
    beta_per_position: Mapping[str, FloatArray]
    beta_linear: Mapping[str, tuple[float, float]]
    dead_distance_from_probe_point: Mapping[str, FloatArray]
    beta_from_probe_point: Mapping[str, FloatArray]
    b_in: Mapping[str, float]
    b_in_sweep_index: Mapping[str, int]
    laser_start_of_range: float
    sweep: FloatArray
    datum: DatumFrame | None = None
    source: str = "<arrays>"
    fixed_laser_scale: float | None = field(default=None, repr=False)

    @property
    def beta_deg(self) -> dict[str, float]:
        """:attr:`beta` in degrees, as Table 7.1 prints it ``{'ab', 'bc', 'ca'}``."""
        return {pair: float(np.degrees(value)) for pair, value in self.beta.items()}

    @property
    def beta_rad(self) -> dict[str, float]:
        """Deprecated since 0.2.0: :attr:`beta` is in radians now; use it."""
        warn_deprecated("TetrahedronCalibration.beta_rad", "TetrahedronCalibration.beta")
        return dict(self.beta)

    @property
    def sphere_forms(self) -> dict[str, FloatArray]:
        """Form error of every fitted joint sphere ``{arm: (K,)}`` plus ``'tip'`` (mm; NaN if unknown)."""
        forms = {arm: np.array([s.form for s in self.joint_spheres[arm]]) for arm in ARMS}
        forms["tip"] = np.array([self.tip.form])
        return forms

    @property
    def joint_centers(self) -> FloatArray:
        """Joint centres, shape (K, 3, 3): position, arm, xyz (mm)."""
        return np.array([[self.joint_spheres[arm][k].center for arm in ARMS] for k in range(len(self.positions))])

    @property
    def tetrahedron(self) -> Tetrahedron:
        """The rigid-body model's :class:`~pcmm_geo.machine.kinematics.model.Tetrahedron` (slider lines + tip)."""
        from pcmm_geo.machine.kinematics.model import Tetrahedron

        return Tetrahedron({arm: self.slider_lines[arm].to_model() for arm in ARMS}, self.tip_center)

    def seed_parameters(self) -> dict[str, dict[str, float]]:
        """The three per-arm numbers of Table 7.1: ``{'a': {'d': .., 'beta_deg': .., 'b': ..}, ...}``.

        Arm ``i``'s ``beta`` and ``b`` are those of the pair ``(i, in)`` (a-b, b-c, c-a).
        """
        return {
            arm: {"d": self.dead_distance[arm], "beta_deg": self.beta_deg[pair], "b": self.b_in[pair]}
            for arm, pair in zip(ARMS, PAIRS, strict=True)
        }

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary of the calibrated values and diagnostics."""
        return {
            "positions": list(self.positions),
            "dead_distance": dict(self.dead_distance),
            "beta_deg": self.beta_deg,
            "b_in": dict(self.b_in),
            "tip_centre": self.tip_center.tolist(),
            "probe_point": self.probe_point.tolist(),
            "probe_point_pairwise": self.probe_point_pairwise.tolist(),
            "skew_distances": dict(self.skew_distances),
            "slider_lines": {
                arm: {
                    "point": line.point.tolist(),
                    "direction": line.direction.tolist(),
                    "laser_scale": line.laser_scale,
                    "laser_offset": line.laser_offset,
                    "straightness": line.straightness,
                    "tip_offset": line.tip_offset,
                }
                for arm, line in self.slider_lines.items()
            },
            "dead_distance_per_position": {k: v.tolist() for k, v in self.dead_distance_per_position.items()},
            "beta_deg_per_position": {k: np.degrees(v).tolist() for k, v in self.beta_per_position.items()},
            "sphere_forms": {k: v.tolist() for k, v in self.sphere_forms.items()},
            "laser_start_of_range": self.laser_start_of_range,
        }
