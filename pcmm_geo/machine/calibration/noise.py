"""How the tetrahedron calibration's errors grow with probing noise (thesis ch. 7; seeded study).

A synthetic machine of known geometry stands in for the real one: the seed's tetrahedron
(Table 3.1 arm directions and offsets) with each slider line moved sideways so that it
misses the tip and the other lines (erratum 9), and laser scales away from 1.  A
simulated external CMM probes every joint ball at each calibration slider position and the
tip ball once: ``points_per_ball`` points on a spiral over the upper three quarters of each
ball, each coordinate with independent Gaussian noise of standard deviation ``sigma``
(mm).  :func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron` then recovers the
geometry, and the errors are measured against the known truth:

* ``tip_center`` -- distance of the fitted tip centre from the true one (mm);
* ``slider_direction`` -- angle between fitted and true slider direction (rad);
* ``slider_point`` -- distance of the fitted foot point from the true foot of the
  perpendicular from the tip onto the line (mm);
* ``laser_scale`` (unitless) and ``laser_offset`` (mm);
* ``dead_distance`` (mm) and ``beta_deg`` (degrees): eqs 7.3 and 7.4 (corrected)
  against the same equations evaluated on the true joint centres and tip.

Each is the largest over the three arms (or arm pairs); :func:`noise_growth_study` reports
the median over seeds.  Run ``python -m pcmm_geo.machine.calibration.noise`` for the table
of ``docs/machine.md``.

Examples
--------
>>> study = noise_growth_study([0.0, 1e-3], seeds=2)
>>> bool(study.rows[0].tip_center < 1e-9), bool(study.rows[1].tip_center > 1e-5)
(True, True)
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_fields
from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.calibration.geometry import angle_between
from pcmm_geo.machine.calibration.probings import ARMS
from pcmm_geo.machine.calibration.result import PAIRS, TetrahedronCalibration
from pcmm_geo.machine.kinematics.model_parts import SliderLine, Tetrahedron

__all__ = [
    "CALIBRATION_LASERS",
    "NoiseGrowth",
    "NoiseGrowthRow",
    "calibration_errors",
    "noise_growth_study",
    "skewed_tetrahedron",
    "synthesise_probings",
    "true_seed_parameters",
]

FloatArray = NDArray[np.float64]

#: laser readings (mm) at the three calibration slider positions, rows = positions, columns = arms a, b, c
CALIBRATION_LASERS = np.array([[12.0, 3.0, 2.0], [35.0, 70.0, 70.0], [51.0, 136.5, 139.0]])
#: sideways shift of each slider line from the tip (mm; the component along the line is dropped):
#: the lines then miss the tip by 15.0, 11.3 and 9.8 mm and each other by 12.7 (ab), 18.4 (bc) and 7.7 (ca) mm
SIDEWAYS = ((0.0, 15.0, 0.0), (12.0, 6.0, 0.0), (-8.0, 10.0, 0.0))
#: laser scales of the synthetic machine (slider travel per laser mm)
LASER_SCALES = (1.02, 0.97, 1.01)
#: probing noise levels of the published table (mm): 0, 0.1, 0.5, 1 and 2 um
SIGMAS = (0.0, 1e-4, 5e-4, 1e-3, 2e-3)


def skewed_tetrahedron(
    sideways: Sequence[ArrayLike] = SIDEWAYS, laser_scales: Sequence[float] = LASER_SCALES
) -> Tetrahedron:
    """The seed's tetrahedron (Table 3.1) with slider lines that miss the tip, and scaled lasers.

    Each line keeps the seed's direction and laser offset; its point (``s = 0``) is the
    foot of the perpendicular from the tip, moved sideways by the part of ``sideways[k]``
    perpendicular to the line.

    Parameters
    ----------
    sideways : sequence of 3 array_like (3,)
        Shift per arm (mm).
    laser_scales : sequence of 3 float
        Slider travel per mm of laser reading.

    Returns
    -------
    Tetrahedron
        Tip centre at the origin (tetrahedron frame = CMM frame here).

    Examples
    --------
    >>> t = skewed_tetrahedron()
    >>> round(float(np.linalg.norm(t.sliders["a"].point - t.tip_center)), 6)
    15.0
    """
    from pcmm_geo.machine.kinematics.model import seed_machine

    nominal = seed_machine().tetrahedron
    sliders = {}
    for k, arm in enumerate(ARMS):
        line = nominal.sliders[arm]
        shift = np.asarray(sideways[k], dtype=float).reshape(3)
        shift = shift - (shift @ line.direction) * line.direction
        foot = nominal.tip_center + ((line.point - nominal.tip_center) @ line.direction) * line.direction
        sliders[arm] = SliderLine(foot + shift, line.direction, float(laser_scales[k]), line.laser_offset)
    return Tetrahedron(sliders, nominal.tip_center)


def _ball(centre: FloatArray, radius: float, count: int, sigma: float, rng: np.random.Generator) -> FloatArray:
    """``count`` points on a spiral over the upper 3/4 of a ball (polar angle to ~120 deg), plus noise."""
    golden = np.pi * (3.0 - np.sqrt(5.0))
    index = np.arange(count)
    height = 1.0 - 1.5 * (index + 0.5) / count
    ring = np.sqrt(1.0 - height**2)
    unit = np.c_[ring * np.cos(golden * index), ring * np.sin(golden * index), height]
    return centre + radius * unit + rng.normal(0.0, sigma, (count, 3))


def synthesise_probings(
    tetrahedron: Tetrahedron,
    lasers: ArrayLike = CALIBRATION_LASERS,
    *,
    points_per_ball: int = 12,
    joint_radius: float = 6.35,
    tip_radius: float = 1.0,
    sigma: float = 0.0,
    seed: int = 0,
) -> dict[str, object]:
    """Simulated external-CMM probings of a known tetrahedron (input of ``calibrate_tetrahedron``).

    Parameters
    ----------
    tetrahedron : Tetrahedron
        The true geometry (CMM frame).
    lasers : array_like, shape (K, 3)
        Laser readings at the K slider positions (mm).
    points_per_ball : int
        Probed points per ball (>= 4).
    joint_radius, tip_radius : float
        Ball radii (mm): 1/2-inch joint balls, the 2 mm ball tip of thesis 3.1.
    sigma : float
        Standard deviation of the Gaussian noise on every coordinate (mm).
    seed : int
        Seed of the noise.

    Returns
    -------
    dict
        ``{"tip": (N, 3), "joint_a": {1: (N, 3), ..., K: (N, 3)}, ...}`` (mm).

    Raises
    ------
    InvalidInputError
        Negative ``sigma``, fewer than 4 points, or readings not of shape (K, 3).

    Examples
    --------
    >>> probings = synthesise_probings(skewed_tetrahedron(), points_per_ball=5)
    >>> sorted(probings), probings["joint_b"][3].shape
    (['joint_a', 'joint_b', 'joint_c', 'tip'], (5, 3))
    """
    readings = np.asarray(lasers, dtype=float)
    if readings.ndim != 2 or readings.shape[1] != 3 or not np.all(np.isfinite(readings)):
        raise InvalidInputError("lasers", "finite readings of shape (K, 3)", f"shape {readings.shape}")
    if not (np.isfinite(sigma) and sigma >= 0):
        raise InvalidInputError("sigma", "a finite standard deviation >= 0 (mm)", str(sigma))
    if points_per_ball < 4:
        raise InvalidInputError("points_per_ball", "at least 4 points per ball", str(points_per_ball))
    rng = np.random.default_rng(seed)
    probings: dict[str, object] = {"tip": _ball(tetrahedron.tip_center, tip_radius, points_per_ball, sigma, rng)}
    for k, arm in enumerate(ARMS):
        joints = tetrahedron.sliders[arm].joint(readings[:, k])
        probings[f"joint_{arm}"] = {
            position + 1: _ball(joints[position], joint_radius, points_per_ball, sigma, rng)
            for position in range(readings.shape[0])
        }
    return probings


def true_seed_parameters(
    tetrahedron: Tetrahedron, lasers: ArrayLike = CALIBRATION_LASERS, *, start_of_range: float = 60.0
) -> tuple[dict[str, float], dict[str, float]]:
    """Eq 7.3 dead distances (mm) and eq 7.4 (corrected) angles (rad) of the true joints, mean over positions.

    Examples
    --------
    >>> dead, beta = true_seed_parameters(skewed_tetrahedron())
    >>> sorted(dead), sorted(beta)
    (['a', 'b', 'c'], ['ab', 'bc', 'ca'])
    """
    readings = np.asarray(lasers, dtype=float)
    arms = np.stack([tetrahedron.sliders[arm].joint(readings[:, k]) for k, arm in enumerate(ARMS)], axis=1)
    arms = arms - tetrahedron.tip_center  # (K, 3 arms, 3)
    lengths = np.linalg.norm(arms, axis=-1)
    dead = {arm: float(np.mean(lengths[:, k] - readings[:, k] - start_of_range)) for k, arm in enumerate(ARMS)}
    beta = {pair: float(np.mean(angle_between(arms[:, k], arms[:, (k + 1) % 3]))) for k, pair in
            enumerate(PAIRS)}
    return dead, beta


def calibration_errors(
    cal: TetrahedronCalibration, tetrahedron: Tetrahedron, lasers: ArrayLike = CALIBRATION_LASERS
) -> dict[str, float]:
    """Errors of a calibration against the true geometry (largest over arms or pairs; see the module notes).

    Returns
    -------
    dict
        ``tip_center``, ``slider_point``, ``laser_offset``, ``dead_distance`` (mm),
        ``slider_direction`` (rad), ``laser_scale`` (unitless), ``beta_deg`` (degrees).

    Examples
    --------
    >>> from pcmm_geo.machine.calibration import calibrate_tetrahedron
    >>> truth = skewed_tetrahedron()
    >>> cal = calibrate_tetrahedron(synthesise_probings(truth), CALIBRATION_LASERS)
    >>> bool(max(calibration_errors(cal, truth).values()) < 1e-6)
    True
    """
    dead, beta = true_seed_parameters(tetrahedron, lasers, start_of_range=cal.laser_start_of_range)
    tip = tetrahedron.tip_center
    direction, point, scale, offset = [], [], [], []
    for arm in ARMS:
        true_line, found = tetrahedron.sliders[arm], cal.slider_lines[arm]
        cosine = float(np.clip(found.direction @ true_line.direction, -1.0, 1.0))
        direction.append(float(np.arccos(cosine)))
        foot = true_line.point + ((tip - true_line.point) @ true_line.direction) * true_line.direction
        # the true slide coordinate is measured from true_line.point: shift the offset to the foot
        true_offset = true_line.laser_offset + (true_line.point - foot) @ true_line.direction
        point.append(float(np.linalg.norm(found.point - foot)))
        scale.append(abs(found.laser_scale - true_line.laser_scale))
        offset.append(abs(found.laser_offset - true_offset))
    return {
        "tip_center": float(np.linalg.norm(cal.tip_center - tip)),
        "slider_direction": max(direction),
        "slider_point": max(point),
        "laser_scale": max(scale),
        "laser_offset": max(offset),
        "dead_distance": max(abs(cal.dead_distance[arm] - dead[arm]) for arm in ARMS),
        "beta_deg": math.degrees(max(abs(cal.beta[pair] - beta[pair]) for pair in PAIRS)),
    }


@renamed_fields(tip_centre="tip_center")
@dataclass(frozen=True)
class NoiseGrowthRow:
    """Median errors over seeds at one probing noise level (units as :func:`calibration_errors`)."""

    sigma: float
    tip_center: float
    slider_direction: float
    slider_point: float
    laser_scale: float
    laser_offset: float
    dead_distance: float
    beta_deg: float


@record
class NoiseGrowth:
    """Result of :func:`noise_growth_study`.

    Attributes
    ----------
    rows : tuple of NoiseGrowthRow
        One per noise level, in the order given.
    seeds : int
        Seeds (independent probing runs) per level; the rows hold medians over them.
    points_per_ball : int
    lasers : ndarray, shape (K, 3)
        Calibration laser readings (mm).
    """

    rows: tuple[NoiseGrowthRow, ...]
    seeds: int
    points_per_ball: int
    lasers: FloatArray

    def to_markdown(self) -> str:
        """The table of ``docs/machine.md`` (noise in µm, errors in µm, µrad, ppm and millidegrees)."""
        lines = [
            "| probe noise σ / µm | tip center / µm | slider direction / µrad | slider point / µm | laser scale / ppm "
            "| laser offset / µm | d / µm | β / mdeg |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for row in self.rows:
            values = (row.tip_center * 1e3, row.slider_direction * 1e6, row.slider_point * 1e3, row.laser_scale * 1e6,
                      row.laser_offset * 1e3, row.dead_distance * 1e3, row.beta_deg * 1e3)
            lines.append(f"| {row.sigma * 1e3:g} | " + " | ".join(f"{v:.3g}" for v in values) + " |")
        return "\n".join(lines)


def noise_growth_study(
    sigmas: Sequence[float] = SIGMAS,
    *,
    seeds: int = 20,
    first_seed: int = 0,
    points_per_ball: int = 12,
    lasers: ArrayLike = CALIBRATION_LASERS,
    tetrahedron: Tetrahedron | None = None,
) -> NoiseGrowth:
    """Median calibration errors over ``seeds`` probing runs for each noise level ``sigmas`` (mm).

    Parameters
    ----------
    sigmas : sequence of float
        Standard deviations of the probing noise per coordinate (mm).
    seeds : int
        Probing runs per level (seeds ``first_seed .. first_seed + seeds - 1``; the same
        seeds at every level, so only the noise amplitude changes).
    first_seed : int
    points_per_ball : int
    lasers : array_like, shape (K, 3)
        Calibration laser readings (mm), K >= 2 positions.
    tetrahedron : Tetrahedron, optional
        True geometry; default :func:`skewed_tetrahedron`.

    Returns
    -------
    NoiseGrowth

    Raises
    ------
    InvalidInputError
        ``seeds`` < 1 or bad probing settings.

    Examples
    --------
    See the module docstring.
    """
    from pcmm_geo.machine.calibration.tetrahedron import calibrate_tetrahedron

    if seeds < 1:
        raise InvalidInputError("seeds", "at least one seed", str(seeds))
    truth = skewed_tetrahedron() if tetrahedron is None else tetrahedron
    readings = np.asarray(lasers, dtype=float)
    rows = []
    for sigma in sigmas:
        runs = []
        for seed in range(first_seed, first_seed + seeds):
            probings = synthesise_probings(truth, readings, points_per_ball=points_per_ball, sigma=sigma, seed=seed)
            runs.append(calibration_errors(calibrate_tetrahedron(probings, readings), truth, readings))
        medians = {key: float(np.median([run[key] for run in runs])) for key in runs[0]}
        rows.append(NoiseGrowthRow(sigma=float(sigma), **medians))
    return NoiseGrowth(tuple(rows), seeds, points_per_ball, readings)


def main(argv: Sequence[str] | None = None) -> None:
    """Print the noise-growth table (``python -m pcmm_geo.machine.calibration.noise``)."""
    parser = argparse.ArgumentParser(description="error growth of the tetrahedron calibration with probing noise")
    parser.add_argument("--seeds", type=int, default=20, help="probing runs per noise level (default 20)")
    parser.add_argument("--points", type=int, default=12, help="probed points per ball (default 12)")
    parser.add_argument("--sigma-um", type=float, nargs="+", default=[s * 1e3 for s in SIGMAS],
                        help="probe noise levels in µm (default 0 0.1 0.5 1 2)")
    args = parser.parse_args(argv)
    study = noise_growth_study([s * 1e-3 for s in args.sigma_um], seeds=args.seeds, points_per_ball=args.points)
    print(f"median over {study.seeds} seeds, {study.points_per_ball} points per ball, "
          f"{study.lasers.shape[0]} slider positions; largest error over the three arms (pairs)")
    print(study.to_markdown())


if __name__ == "__main__":
    main()
