"""The seed's external-CMM calibration rebuilt from the numbers printed in Appendices C and D.

The thesis does not print its CMM₁ file (``CMM.csv``), only numbers derived from it.
This module rebuilds sphere centres that are consistent with every printed number, so
that :func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron` can be checked against
Table 7.1.  The derived files ship in ``pcmm_geo/data/appendix_cd/`` and
:func:`build_appendix_cd` regenerates them.

Printed inputs (all in :data:`APPENDIX_C` / :data:`APPENDIX_D`):

* Appendix C lines 22-27: laser readings ``la1 .. lc2`` at slider positions 1 and 2.
* Appendix C lines 93, 97, 101 (comments): the straight lines ``d = m l + c`` through the
  two dead distances of each arm, printed to 15 digits; evaluated at the readings they
  give the dead distances to ~1e-13 mm (Appendix D's ``D1`` prints them to 4 decimals).
* Appendix C lines 136, 140, 144 (comments): the same for the arm angles
  (``beta_ca`` on ``la``, ``beta_ab`` on ``lb``, ``beta_bc`` on ``lc``); Appendix D's
  ``Beta`` rows 1-2 print them to 4 decimals.
* Appendix D line 33: ``v1``, the unit vectors from the tip to the joints at position 1
  (4 decimals); their pairwise angles equal ``Beta`` row 1, which identifies them.
* Appendix D ``D2`` and ``Beta`` rows 4-5: dead distances and angles seen from the
  theoretical probe point (eq 7.2).

Construction (frame of Appendix C: the probe-tip centre at the origin):

1. joint ``i`` at position ``k`` lies at distance ``L_ik = l_ik + 60 + d_ik`` from the tip;
2. position 1: the three unit vectors with the exact printed angles, rotated onto
   ``v1`` (orthogonal Procrustes; they then agree with ``v1`` to 6e-5);
3. position 2 and the theoretical probe point ``q`` (6 unknowns: rotation of the
   position-2 unit-vector triad and ``q``): least squares on ``D2`` and Beta rows 4-5
   (12 equations).  These fix ``q`` and the triad except for one rotation about the axis
   tip -> ``q`` that leaves every printed number unchanged; it is fixed by asking, with a
   small weight, that the seed's eq 7.2 construction (average of the pairwise
   closest-point midpoints of the slider lines) return ``q``.  Both are met: every
   printed number is reproduced to 5e-5 (its last digit) and the eq 7.2 construction
   lands 2e-3 mm from ``q`` (reported by :func:`reconstruct_appendix_cd`), so the printed
   numbers are mutually consistent and determine the geometry.

Sphere sizes and roundness were not printed; the export gives them as ``nan``.
Table 7.1's ``b_in`` needs the laser sweep of section 7.2 (not printed) and is not
reproduced.

Examples
--------
>>> rebuilt = reconstruct_appendix_cd()
>>> bool(rebuilt.max_printed_residual < 1e-4)
True
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "APPENDIX_C",
    "APPENDIX_D",
    "DATA_FOLDER",
    "TABLE_6_2",
    "TABLE_7_1",
    "AppendixReconstruction",
    "appendix_cd_files",
    "build_appendix_cd",
    "reconstruct_appendix_cd",
]

FloatArray = NDArray[np.float64]
DATA_FOLDER = "appendix_cd"

#: Appendix C: laser readings (mm) and the 15-digit line coefficients printed as comments.
APPENDIX_C = {
    "lasers": np.array([[50.793, 136.507, 139.025], [12.3437, 2.43262, 1.7608]]),
    # d = slope * laser + intercept, arms a, b, c (lines 93, 97, 101)
    "dead_slope": np.array([0.026627049789461, -0.044612765097454, -0.013374610524288]),
    "dead_intercept": np.array([3.136353928514989e2, 3.158420181264962e2, 3.103580364947039e2]),
    # beta = slope * laser + intercept for pairs ab (on lb), bc (on lc), ca (on la) (lines 136-144)
    "beta_slope": np.array([-0.002311030128832, 0.010869972519353, 0.014048554826179]),
    "beta_intercept": np.array([68.407001290625388, 68.266075710813610, 68.257395830445560]),
    "start_of_range": 60.0,
    "probe2": np.array([195.5720, -1.3245, 230.3101]),
}

#: Appendix D lines 23-35: dead distances D1 (from the tip) and D2 (from the theoretical
#: probe), Beta rows (ab, bc, ca): 1-2 per position from the tip, 3 their mean, 4-5 from the
#: theoretical probe, 6 their mean; v1 unit vectors tip -> joint at position 1.
APPENDIX_D = {
    "D1": np.array([[314.9879, 309.7521, 308.4986], [313.9641, 315.7335, 310.3345]]),
    "D2": np.array([[313.7082, 281.4081, 279.0626], [312.4648, 287.1042, 280.8018]]),
    "Beta": np.array(
        [
            [68.0915, 69.7773, 68.9710],
            [68.4014, 68.2852, 68.4308],
            [68.2465, 69.0312, 68.7009],
            [71.0336, 74.6816, 72.0658],
            [71.4543, 74.9495, 71.5526],
            [71.2440, 74.8155, 71.8092],
        ]
    ),
    "v1": np.array([[-0.6578, 0.0019, -0.7532], [0.3050, 0.5733, -0.7604], [0.3193, -0.5705, -0.7567]]),
}

#: Table 7.1: arm -> (d_i mm, beta_in degrees, b_in mm).
TABLE_7_1 = {"a": (314.48, 68.25, 454.17), "b": (312.74, 69.03, 462.47), "c": (309.42, 68.70, 461.67)}

#: Table 6.2 as printed; its header swaps units (erratum 8): beta is in degrees and b in mm.
#: Columns d_i, d_in (mm), beta_in (deg), b (mm), sigma_err (mm), number of points.
TABLE_6_2 = {
    "Test 1": (320.94, 372.83, 79.93, 493.01, 0.91, 6),
    "Test 2": (363.95, 374.49, 62.75, 421.38, 0.76, 11),
    "Test 3": (383.07, 343.57, 69.16, 453.62, 0.11, 3),
    "Expected": (349.40, 354.02, 68.36, 434.60, float("nan"), 0),
}


@dataclass(frozen=True)
class AppendixReconstruction:
    """Sphere centres rebuilt from Appendices C and D (tip at the origin, mm).

    Attributes
    ----------
    centres : ndarray, shape (2, 3, 3)
        Joint centres: position (1, 2), arm (a, b, c), xyz.
    tip : ndarray, shape (3,)
        Probe-tip centre (the origin).
    lasers : ndarray, shape (2, 3)
        Printed laser readings.
    dead_distance, beta_deg : ndarray, shape (2, 3)
        Full-precision values from the printed line coefficients (arms a, b, c; pairs ab, bc, ca).
    theoretical_probe : ndarray, shape (3,)
        The theoretical probe point ``q`` consistent with ``D2`` and Beta rows 4-5.
    max_printed_residual : float
        Largest mismatch with any printed D2 / Beta rows 4-5 number (mm or degrees).
    eq_7_2_gap : float
        Distance between ``q`` and the seed's eq 7.2 construction on the rebuilt lines (mm).
    """

    centres: FloatArray
    tip: FloatArray
    lasers: FloatArray
    dead_distance: FloatArray
    beta_deg: FloatArray
    theoretical_probe: FloatArray
    max_printed_residual: float
    eq_7_2_gap: float


def _triad(beta_ab: float, beta_bc: float, beta_ca: float) -> FloatArray:
    """Three unit vectors (rows a, b, c) with the given pairwise angles (degrees), right-handed."""
    cos_ab, cos_bc, cos_ca = np.cos(np.radians([beta_ab, beta_bc, beta_ca]))
    unit_a = np.array([1.0, 0.0, 0.0])
    unit_b = np.array([cos_ab, np.sqrt(1.0 - cos_ab**2), 0.0])
    c_x = cos_ca
    c_y = (cos_bc - unit_b[0] * c_x) / unit_b[1]
    unit_c = np.array([c_x, c_y, np.sqrt(1.0 - c_x**2 - c_y**2)])
    return np.array([unit_a, unit_b, unit_c])


def _rotate_onto(rows: FloatArray, target: FloatArray) -> FloatArray:
    """Proper rotation of ``rows`` that best matches ``target`` (orthogonal Procrustes)."""
    u, _, vt = np.linalg.svd(rows.T @ target)
    sign = np.sign(np.linalg.det(u @ vt))
    rotation = u @ np.diag([1.0, 1.0, sign]) @ vt
    return rows @ rotation


def reconstruct_appendix_cd(seed: int = 0) -> AppendixReconstruction:
    """Rebuild joint centres consistent with every number printed in Appendices C and D.

    Parameters
    ----------
    seed : int
        Seed of the multi-start for the position-2 orientation (result independent of it
        in practice; the best of 8 starts is kept).

    Returns
    -------
    AppendixReconstruction

    Examples
    --------
    >>> rebuilt = reconstruct_appendix_cd()
    >>> np.round(np.linalg.norm(rebuilt.centres[0, 0]), 4)  # 50.793 + 60 + d_a1
    np.float64(425.7809)
    """
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation

    from pcmm_geo.fit.skew import mean_pairwise_midpoint
    from pcmm_geo.machine.calibration.geometry import angle_between_deg

    lasers = APPENDIX_C["lasers"]
    dead = APPENDIX_C["dead_slope"] * lasers + APPENDIX_C["dead_intercept"]
    # beta pairs ab, bc, ca regressed on lasers b, c, a
    beta = APPENDIX_C["beta_slope"] * lasers[:, [1, 2, 0]] + APPENDIX_C["beta_intercept"]
    reach = lasers + APPENDIX_C["start_of_range"] + dead  # (2, 3) tip-to-joint distances
    units_1 = _rotate_onto(_triad(*beta[0]), APPENDIX_D["v1"])
    centres_1 = reach[0][:, None] * units_1
    base_2 = _rotate_onto(_triad(*beta[1]), APPENDIX_D["v1"])
    d2 = APPENDIX_D["D2"]
    beta_t = APPENDIX_D["Beta"][3:5]

    def unpack(params: FloatArray) -> tuple[FloatArray, FloatArray]:
        rotation = Rotation.from_rotvec(params[:3]).as_matrix()
        return reach[1][:, None] * (base_2 @ rotation.T), params[3:]

    def printed_residuals(params: FloatArray) -> FloatArray:
        centres_2, probe = unpack(params)
        out = []
        for k, centres in enumerate((centres_1, centres_2)):
            rel = centres - probe
            out.append(np.linalg.norm(rel, axis=1) - lasers[k] - APPENDIX_C["start_of_range"] - d2[k])
            out.append(angle_between_deg(rel, rel[[1, 2, 0]]) - beta_t[k])
        return np.concatenate(out)

    def eq_7_2_gap(params: FloatArray) -> FloatArray:
        centres_2, probe = unpack(params)
        directions = centres_1 - centres_2
        return mean_pairwise_midpoint(centres_1, directions, pairs=((0, 1), (1, 2), (2, 0))) - probe

    def residuals(params: FloatArray) -> FloatArray:
        return np.concatenate([printed_residuals(params), 1e-3 * eq_7_2_gap(params)])

    rng = np.random.default_rng(seed)
    best = None
    for _ in range(8):
        start = np.concatenate([rng.normal(0.0, 0.2, 3), rng.normal(0.0, 40.0, 3)])
        found = least_squares(residuals, start, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        if best is None or found.cost < best.cost:
            best = found
    assert best is not None
    centres_2, probe = unpack(best.x)
    return AppendixReconstruction(
        centres=np.stack([centres_1, centres_2]),
        tip=np.zeros(3),
        lasers=lasers.copy(),
        dead_distance=dead,
        beta_deg=beta,
        theoretical_probe=probe,
        max_printed_residual=float(np.abs(printed_residuals(best.x)).max()),
        eq_7_2_gap=float(np.linalg.norm(eq_7_2_gap(best.x))),
    )


def appendix_cd_files() -> tuple[Path, Path]:
    """Paths of the shipped derived files ``(cmm_export.csv, lasers.csv)``.

    Examples
    --------
    >>> [p.name for p in appendix_cd_files()]
    ['cmm_export.csv', 'lasers.csv']
    """
    folder = resources.files("pcmm_geo") / "data" / DATA_FOLDER
    return Path(str(folder / "cmm_export.csv")), Path(str(folder / "lasers.csv"))


def build_appendix_cd(folder: str | Path, *, overwrite: bool = False) -> tuple[Path, Path]:
    """Write the rebuilt element-level export and laser readings into ``folder``.

    Raises
    ------
    OutputExistsError
        A file exists and ``overwrite`` is false.
    """
    from pcmm_geo.machine.calibration.probings import write_element_export, write_lasers_csv

    rebuilt = reconstruct_appendix_cd()
    target = Path(folder)
    target.mkdir(parents=True, exist_ok=True)
    export = write_element_export(target / "cmm_export.csv", rebuilt.centres, rebuilt.tip, overwrite=overwrite)
    lasers = write_lasers_csv(target / "lasers.csv", (1, 2), rebuilt.lasers, overwrite=overwrite)
    return export, lasers
