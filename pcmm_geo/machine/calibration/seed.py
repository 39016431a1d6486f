"""The seed's external-CMM calibration rebuilt from the numbers printed in Appendices C and D.

The thesis does not print its CMM₁ file (``CMM.csv``), only numbers derived from it.
This module rebuilds sphere centers that are consistent with every printed number but one
(``probe2``, see below), so that :func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron`
can be checked against Table 7.1.  The derived files ship in ``pcmm_geo/data/appendix_cd/`` and
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
  (4 decimals); their pairwise angles equal ``Beta`` row 1, which identifies them.  Used
  with its ``z`` reversed (:data:`V1_MACHINE_AXES`, see "Handedness" below).
* Appendix D ``D2`` and ``Beta`` rows 4-5: dead distances and angles seen from the
  theoretical probe point (eq 7.2).

Construction (frame of Appendix C: the probe-tip center at the origin; axes of the machine):

1. joint ``i`` at position ``k`` lies at distance ``L_ik = l_ik + 60 + d_ik`` from the tip;
2. position 1: the three unit vectors with the exact printed angles, rotated onto
   ``v1`` with its ``z`` reversed (orthogonal Procrustes; they then agree with it to 6e-5);
3. position 2 and the theoretical probe point ``q`` (6 unknowns: rotation of the
   position-2 unit-vector triad and ``q``): least squares on ``D2`` and Beta rows 4-5
   (12 equations).  These fix ``q`` and the triad except for one rotation about the axis
   tip -> ``q`` that leaves every printed number unchanged; it is fixed by asking, with a
   small weight, that the seed's eq 7.2 construction (average of the pairwise
   closest-point midpoints of the slider lines) return ``q``.  Both are met: every
   number listed above is reproduced to 5e-5 (its last digit) and the eq 7.2 construction
   lands 2e-3 mm from ``q`` (reported by :func:`reconstruct_appendix_cd`), so the printed
   numbers are mutually consistent and determine the geometry.

Handedness.  Every printed number except ``v1`` is a length or an angle, and both are the
same for the tetrahedron and its mirror image; ``v1`` fixes the handedness only if one
knows the frame it is written in, and the thesis does not say.  Taken as tip -> joint in a
right-handed frame, as printed, the triad a, b, c turns counter-clockwise seen from the
joints (``det v1 = +0.84``), the machine's turns clockwise: put into the machine, the
printed triad hangs the tip *above* the pivots (``pcmm kinematics forward --heights-mm 400
400 400`` gave z = 709.4 mm with pivots at 400 mm).  The machine fixes the handedness:

* thesis 2.6.4: arms a, b, c run *clockwise seen from above*; Table 4.1 and Appendix D's
  ``pp`` put pivot a at -x, b at +y, c at -y; the probe hangs below the pivots (Table
  4.2 / Appendix E: probe at z = 126.7 mm, 79.7 mm corrected, under pivots at 381-401 mm);
  so in a right-handed frame with ``z`` up the tip -> joint triad has ``det < 0``
  (:func:`~pcmm_geo.machine.kinematics.dpkm.tetrahedron_directions` on Table 3.1:
  ``det = -0.83``);
* Appendix D's ``pp`` places each pivot at ``r_i (v1_x, v1_y)`` (the printed x/y ratios
  agree with ``v1``'s to 9 digits, ``r`` = 404-408 mm) with heights upward and the probe
  below: the seed's own machine frame reads ``v1``'s ``x, y`` as the plan directions of
  the arms and its ``z`` downward.

So the tip -> joint directions in the machine's right-handed frame are ``v1`` with ``z``
reversed (``det = -0.84``), which is what is used.  (CMM₁'s frame was presumably another
orientation of the part; only its handedness matters, and no right-handed frame can hold
the printed ``v1`` as tip -> joint vectors of this machine.)  The shipped files are in the
machine's axes: tip at the origin, joints above it, arm a towards -x, b towards +y.

Sphere sizes and roundness were not printed; the export gives them as ``nan``.
Table 7.1's ``b_in`` needs the laser sweep of section 7.2 (not printed) and is not
reproduced.

``probe2`` (Appendix C line 79, "value determined from Equation 7.2") is *not* reproduced
and cannot be: it lies 302.1 mm from the tip in the tip-at-origin frame of Appendix C
lines 29-39 where lines 106-111 use it, but the only points at the ``D2`` row-1 distances
from the position-1 joints (fixed, up to rotation and reflection, by ``D1`` and Beta row 1)
lie 38.87 mm and 692.5 mm from the tip (row 2: 38.87 and 548.6 mm).  Evaluated with
``probe2``, lines 106-111 would give ``D2`` 201-304 mm larger than printed.  ``probe2`` must
have been written in another frame (e.g. CMM₁'s, before the translation of lines 36-39);
it is kept in :data:`APPENDIX_C` for reference only (``tests/machine/test_errata.py``).

Examples
--------
>>> rebuilt = reconstruct_appendix_cd()
>>> bool(rebuilt.max_printed_residual < 1e-4)
True
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._deprecation import renamed_fields
from pcmm_geo._records import record

__all__ = [
    "APPENDIX_C",
    "APPENDIX_D",
    "DATA_FOLDER",
    "TABLE_6_2",
    "TABLE_7_1",
    "V1_MACHINE_AXES",
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
    # line 79, "value determined from Equation 7.2": not in the tip-at-origin frame (see the module notes)
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

#: Factors taking Appendix D's printed ``v1`` to tip -> joint directions in the machine's
#: right-handed frame (``z`` up, probe below the pivots): ``z`` reversed (module notes, "Handedness").
V1_MACHINE_AXES = np.array([1.0, 1.0, -1.0])

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


@renamed_fields(centres="centers")
@record
class AppendixReconstruction:
    """Sphere centers rebuilt from Appendices C and D (tip at the origin, machine axes, mm).

    Attributes
    ----------
    centers : ndarray, shape (2, 3, 3)
        Joint centers: position (1, 2), arm (a, b, c), xyz.
    tip : ndarray, shape (3,)
        Probe-tip center (the origin).
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

    centers: FloatArray
    tip: FloatArray
    lasers: FloatArray
    dead_distance: FloatArray
    beta_deg: FloatArray
    theoretical_probe: FloatArray
    max_printed_residual: float
    eq_7_2_gap: float


def _triad(beta_ab: float, beta_bc: float, beta_ca: float, handedness: float = 1.0) -> FloatArray:
    """Three unit vectors (rows a, b, c) with the given pairwise angles (degrees).

    ``det`` of the rows has the sign of ``handedness`` (+1: ``a, b, c`` turn counter-clockwise
    seen from where they point; -1: clockwise, as the machine's arms seen from above).
    """
    cos_ab, cos_bc, cos_ca = np.cos(np.radians([beta_ab, beta_bc, beta_ca]))
    unit_a = np.array([1.0, 0.0, 0.0])
    unit_b = np.array([cos_ab, np.sqrt(1.0 - cos_ab**2), 0.0])
    c_x = cos_ca
    c_y = (cos_bc - unit_b[0] * c_x) / unit_b[1]
    unit_c = np.array([c_x, c_y, np.copysign(np.sqrt(1.0 - c_x**2 - c_y**2), handedness)])
    return np.array([unit_a, unit_b, unit_c])


def _rotate_onto(rows: FloatArray, target: FloatArray) -> FloatArray:
    """Proper rotation of ``rows`` that best matches ``target`` (orthogonal Procrustes)."""
    u, _, vt = np.linalg.svd(rows.T @ target)
    sign = np.sign(np.linalg.det(u @ vt))
    rotation = u @ np.diag([1.0, 1.0, sign]) @ vt
    return rows @ rotation


def reconstruct_appendix_cd(seed: int = 0) -> AppendixReconstruction:
    """Rebuild joint centers consistent with the numbers printed in Appendices C and D (not ``probe2``).

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
    >>> np.round(np.linalg.norm(rebuilt.centers[0, 0]), 4)  # 50.793 + 60 + d_a1
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
    directions_1 = APPENDIX_D["v1"] * V1_MACHINE_AXES  # machine axes: z up, tip below the joints
    handedness = float(np.sign(np.linalg.det(directions_1)))  # -1: a, b, c clockwise seen from above
    units_1 = _rotate_onto(_triad(*beta[0], handedness), directions_1)
    centres_1 = reach[0][:, None] * units_1
    base_2 = _rotate_onto(_triad(*beta[1], handedness), directions_1)
    d2 = APPENDIX_D["D2"]
    beta_t = APPENDIX_D["Beta"][3:5]

    def unpack(params: FloatArray) -> tuple[FloatArray, FloatArray]:
        rotation = Rotation.from_rotvec(params[:3]).as_matrix()
        return reach[1][:, None] * (base_2 @ rotation.T), params[3:]

    def printed_residuals(params: FloatArray) -> FloatArray:
        centres_2, probe = unpack(params)
        out = []
        for k, centers in enumerate((centres_1, centres_2)):
            rel = centers - probe
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
        centers=np.stack([centres_1, centres_2]),
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
    export = write_element_export(target / "cmm_export.csv", rebuilt.centers, rebuilt.tip, overwrite=overwrite)
    lasers = write_lasers_csv(target / "lasers.csv", (1, 2), rebuilt.lasers, overwrite=overwrite)
    return export, lasers
