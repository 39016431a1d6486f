"""ISO 10360-5 single-stylus probing test on a calibrated sphere: P_FTU (form) and P_STU (size).

25 points are probed on a test sphere (diameter 10-51 mm in the standard) and a Gaussian
(least-squares) sphere is fitted to them:

* ``P_FTU`` -- probing form error: range of the radial distances, i.e. the largest minus the
  smallest signed residual of the Gaussian fit;
* ``P_STU`` -- probing size error: fitted diameter minus calibrated diameter.

Target pattern (:func:`sphere_probing_pattern`), as the standard lays it out, in the
sphere's frame with the pole on the stylus side: one point on the pole; four points evenly
spread in azimuth 22.5° below the pole; eight points 45° below the pole; four points 67.5°
below the pole; eight points on the equator (90° below the pole).  Each ring after the
first is turned 22.5° in azimuth relative to the ring before it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_fields, renamed_parameters, warn_deprecated
from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit import as_points

__all__ = [
    "PATTERN_RINGS",
    "STANDARD_POINT_COUNT",
    "ProbingResult",
    "evaluate_probing",
    "read_points_csv",
    "read_reference_diameter",
    "sphere_probing_pattern",
]

FloatArray = NDArray[np.float64]

#: (polar angle below the pole in degrees, number of points, azimuth turn of the ring in degrees)
PATTERN_RINGS = ((0.0, 1, 0.0), (22.5, 4, 0.0), (45.0, 8, 22.5), (67.5, 4, 45.0), (90.0, 8, 67.5))
#: points of the standard's probing test
STANDARD_POINT_COUNT = 25


@renamed_parameters(centre="center")
def sphere_probing_pattern(
    center: ArrayLike = (0.0, 0.0, 0.0),
    radius: float = 12.5,
    *,
    pole: ArrayLike = (0.0, 0.0, 1.0),
    azimuth: float = 0.0,
) -> FloatArray:
    """The 25 target points of the ISO 10360-5 probing test.

    Parameters
    ----------
    center : array_like, shape (3,)
        Sphere center (mm).
    radius : float
        Sphere radius (mm), > 0.
    pole : array_like, shape (3,)
        Direction of the pole from the center (towards the probe); normalised here.
    azimuth : float
        Extra rotation of the whole pattern about the pole axis (rad).  Azimuth 0 lies along the
        machine x axis projected normal to the pole (along y when the pole is near x).

    Returns
    -------
    ndarray, shape (25, 3)
        Pole first, then the rings in the order of :data:`PATTERN_RINGS`.

    Raises
    ------
    InvalidInputError
        Non-positive radius, zero pole vector.

    Examples
    --------
    >>> pts = sphere_probing_pattern(radius=10.0)
    >>> pts.shape, pts[0].tolist()
    ((25, 3), [0.0, 0.0, 10.0])
    """
    if not (math.isfinite(radius) and radius > 0):
        raise InvalidInputError("radius", "a positive radius in mm", repr(radius))
    axis = np.asarray(pole, dtype=float)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) == 0:
        raise InvalidInputError("pole", "a non-zero 3-vector", f"{axis.tolist()}")
    c = np.asarray(center, dtype=float)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise InvalidInputError("center", "a finite 3-vector in mm", f"{c.tolist()}")
    local = []
    for polar_deg, count, turn_deg in PATTERN_RINGS:
        polar = math.radians(polar_deg)
        for m in range(count):
            phi = azimuth + math.radians(turn_deg) + 2 * math.pi * m / count
            local.append([math.sin(polar) * math.cos(phi), math.sin(polar) * math.sin(phi), math.cos(polar)])
    unit_points = np.asarray(local)
    # pattern frame: pole d, azimuth 0 along the machine x axis projected normal to d (y when d ~ x)
    d = axis / np.linalg.norm(axis)
    reference = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = reference - (reference @ d) * d
    e1 /= np.linalg.norm(e1)
    frame = np.vstack([e1, np.cross(d, e1), d])
    return c + radius * unit_points @ frame


@renamed_fields(centre="center")
@record
class ProbingResult:
    """ISO 10360-5 probing errors.

    Attributes
    ----------
    form_error : float
        ``P_FTU``, range of the radial residuals (mm).
    size_error : float
        ``P_STU``, fitted minus calibrated diameter (mm).
    fitted_diameter, reference_diameter : float
        mm.
    center : ndarray, shape (3,)
        Fitted center (mm).
    residuals : ndarray, shape (N,)
        Signed radial residuals (mm).
    n : int
        Number of points (25 in the standard).
    mpe_form, mpe_size : float or None
        Stated MPEs (mm), if any.
    form_conforms, size_conforms : bool or None
        ``P_FTU <= MPE_PFTU``, ``|P_STU| <= MPE_PSTU`` (simple acceptance), None without MPE.
    form_verdict, size_verdict : str
        With a test uncertainty: the ISO 14253-1 verdicts (``"PASS"``, ``"FAIL"``,
        ``"NOT PROVEN"``, :func:`pcmm_geo.uncertainty.conformity.decide_conformity`); the
        ``*_conforms`` fields are then True only for ``PASS``.  "" otherwise.
    test_uncertainty : tuple of float or None
        ``(U_form, U_size)`` (mm) used by the decision.
    decision_rule : str
    complete : bool
        The data set has the standard's 25 points; a partial set (evaluated only on request)
        never passes: :attr:`passed` is then None or False and :attr:`verdict` starts with
        "INCOMPLETE".
    """

    form_error: float
    size_error: float
    fitted_diameter: float
    reference_diameter: float
    center: FloatArray
    residuals: FloatArray
    n: int
    mpe_form: float | None
    mpe_size: float | None
    form_conforms: bool | None
    size_conforms: bool | None
    form_verdict: str = ""
    size_verdict: str = ""
    test_uncertainty: tuple[float, float] | None = None
    decision_rule: str = "simple acceptance (zero guard band)"
    complete: bool = True

    @property
    def passed(self) -> bool | None:
        """All stated MPEs met on a complete test (False on any exceeded MPE; None without MPE or when incomplete)."""
        verdicts = [v for v in (self.form_conforms, self.size_conforms) if v is not None]
        if not verdicts:
            return None
        if not all(verdicts):
            return False
        return True if self.complete else None

    @property
    def verdict(self) -> str:
        """"PASS", "FAIL", "NOT PROVEN" (ISO 14253-1 rule), "no MPE stated", or "INCOMPLETE (n of 25 points): ..."."""
        stated = [(conforms, word) for conforms, word in ((self.form_conforms, self.form_verdict),
                                                          (self.size_conforms, self.size_verdict))
                  if conforms is not None]
        words = [word or ("PASS" if conforms else "FAIL") for conforms, word in stated]
        if not words:
            text = "no MPE stated"
        elif "FAIL" in words:
            text = "FAIL"
        elif "NOT PROVEN" in words:
            text = "NOT PROVEN"
        else:
            text = "PASS" if self.complete else "MPEs met on these points, no acceptance verdict"
        if self.complete:
            return text
        return f"INCOMPLETE ({self.n} of {STANDARD_POINT_COUNT} points): {text}"


def evaluate_probing(
    points: ArrayLike,
    reference_diameter: float,
    *,
    mpe_form: float | None = None,
    mpe_size: float | None = None,
    test_uncertainty: tuple[float, float] | None = None,
    allow_incomplete: bool = False,
) -> ProbingResult:
    r"""P_FTU and P_STU from points probed on a calibrated sphere (Gaussian sphere fit).

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Probed points (mm); the standard uses 25 (:func:`sphere_probing_pattern`).
    reference_diameter : float
        Calibrated sphere diameter (mm).
    mpe_form, mpe_size : float, optional
        MPE_PFTU and MPE_PSTU (mm).
    test_uncertainty : tuple of float, optional
        Expanded uncertainties ``(U_form, U_size)`` (mm, 95 %) of the two test values; when
        given the ISO 14253-1 rule decides (guard bands of U), else simple acceptance.
    allow_incomplete : bool
        Evaluate a data set of other than 25 points (at least 5); the result is then marked
        incomplete and never passes.

    Returns
    -------
    ProbingResult

    Raises
    ------
    InvalidInputError
        Non-positive diameter or MPE, bad point array.
    IncompleteTestError
        Not 25 points and ``allow_incomplete`` is False.
    TooFewPointsError, DegenerateGeometryError, ConvergenceError
        From the sphere fit.

    See Also
    --------
    sphere_probing_pattern : the standard's 25 points
    pcmm_geo.fit.fit_sphere : the Gaussian sphere fit used

    Notes
    -----
    ISO 10360-5 [1]_: a Gaussian (least-squares) sphere is fitted to the points; the probing
    form error is the range of the radial distances and the probing size error the fitted
    diameter less the calibrated one,

    .. math::

        P_\mathrm{FTU} = \max_i r_i - \min_i r_i , \qquad
        P_\mathrm{STU} = D_\mathrm{fitted} - D_\mathrm{calibrated} .

    With ``test_uncertainty`` the verdicts follow ISO 14253-1 [2]_.

    References
    ----------
    .. [1] ISO 10360-5:2010, *Geometrical product specifications (GPS) -- Acceptance and reverification tests
           for coordinate measuring machines (CMM) -- Part 5: CMMs using single and multiple stylus contacting
           probing systems*.
    .. [2] ISO 14253-1:2017, *Geometrical product specifications (GPS) -- Inspection by measurement of
           workpieces and measuring equipment -- Part 1: Decision rules for verifying conformity or
           nonconformity with specifications*.

    Examples
    --------
    >>> pts = sphere_probing_pattern((10.0, 20.0, 30.0), 12.5)
    >>> res = evaluate_probing(pts, 25.0)
    >>> round(res.form_error, 12) + 0.0, round(res.size_error, 12) + 0.0
    (0.0, 0.0)
    >>> evaluate_probing(pts[:9], 25.0, mpe_form=0.001, allow_incomplete=True).verdict
    'INCOMPLETE (9 of 25 points): MPEs met on these points, no acceptance verdict'
    """
    from pcmm_geo.errors import IncompleteTestError
    from pcmm_geo.fit import fit_sphere

    if not (isinstance(reference_diameter, (int, float)) and math.isfinite(reference_diameter)
            and reference_diameter > 0):
        raise InvalidInputError("reference_diameter", "a positive diameter in mm", repr(reference_diameter))
    for name, value in (("mpe_form", mpe_form), ("mpe_size", mpe_size)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InvalidInputError(name, "a positive length in mm or None", repr(value))
    pts = as_points(points, element="sphere", min_points=5)
    complete = len(pts) == STANDARD_POINT_COUNT
    if not complete and not allow_incomplete:
        raise IncompleteTestError("ISO 10360-5", STANDARD_POINT_COUNT, len(pts), unit="points on the test sphere")
    fit = fit_sphere(pts)
    residuals = np.asarray(fit.residuals, dtype=float)
    form = float(residuals.max() - residuals.min())
    diameter = 2.0 * float(fit.radius)
    size = diameter - float(reference_diameter)
    form_ok = None if mpe_form is None else form <= mpe_form
    size_ok = None if mpe_size is None else abs(size) <= mpe_size
    verdicts = ("", "")
    rule = "simple acceptance (zero guard band)"
    if test_uncertainty is not None:
        from pcmm_geo.uncertainty.conformity import DECISION_RULE_TEXT, decide_conformity

        u_form, u_size = (float(v) for v in test_uncertainty)
        verdicts = (
            "" if mpe_form is None else decide_conformity(form, u_form, upper_limit=mpe_form).verdict,
            "" if mpe_size is None else decide_conformity(abs(size), u_size, upper_limit=mpe_size).verdict,
        )
        form_ok = None if mpe_form is None else verdicts[0] == "PASS"
        size_ok = None if mpe_size is None else verdicts[1] == "PASS"
        rule = DECISION_RULE_TEXT
    return ProbingResult(
        form_error=form,
        size_error=size,
        fitted_diameter=diameter,
        reference_diameter=float(reference_diameter),
        center=np.asarray(fit.center, dtype=float),
        residuals=residuals,
        n=len(pts),
        mpe_form=mpe_form,
        mpe_size=mpe_size,
        form_conforms=form_ok,
        size_conforms=size_ok,
        form_verdict=verdicts[0],
        size_verdict=verdicts[1],
        test_uncertainty=None if test_uncertainty is None else (u_form, u_size),
        decision_rule=rule,
        complete=complete,
    )


def read_points_csv(path: str | Path) -> FloatArray:
    """Deprecated since 0.2.0 (removed in 0.3.0): use :func:`pcmm_geo.io.read_points`, the one point-file reader.

    Examples
    --------
    >>> import warnings
    >>> from importlib.resources import files
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore", DeprecationWarning)
    ...     read_points_csv(files("pcmm_geo") / "data/examples/iso10360_5_sphere.csv").shape
    (25, 3)
    """
    from pcmm_geo.io.points import read_points

    warn_deprecated("pcmm_geo.artefacts.read_points_csv", "pcmm_geo.io.read_points", stacklevel=3)
    return read_points(path)


_DIAMETER_KEY = "reference_diameter_mm"


def read_reference_diameter(path: str | Path) -> float | None:
    """The calibrated sphere diameter (mm) a points file states in a ``# reference_diameter_mm: D`` comment.

    Returns None when the file states none.

    Raises
    ------
    FileFormatError
        The line is there but its value is not a positive number, or it appears twice.

    Examples
    --------
    >>> from importlib.resources import files
    >>> read_reference_diameter(files("pcmm_geo") / "data/examples/iso10360_5_sphere.csv")
    25.0004
    """
    from pcmm_geo.errors import FileFormatError
    from pcmm_geo.io.text import decode_block, iter_blocks

    found: float | None = None
    # a comment may stand anywhere in a point file: every block is read, but only a block holding a '#'
    # is decoded line by line (a scanner-size file is scanned at the speed of a byte search, in bounded memory)
    lines = (line for block in iter_blocks(path) if b"#" in block.data for line in decode_block(path, block))
    for number, text in lines:
        body = text.strip()
        if not body.startswith("#") or ":" not in body:
            continue
        key, _, value = body.lstrip("#").partition(":")
        if key.strip().lower() != _DIAMETER_KEY:
            continue
        try:
            diameter = float(value.strip())
        except ValueError:
            diameter = math.nan
        if not (math.isfinite(diameter) and diameter > 0):
            raise FileFormatError(str(path), f"{_DIAMETER_KEY}: expected a positive number, got {value.strip()!r}",
                                  line=number)
        if found is not None:
            raise FileFormatError(str(path), f"{_DIAMETER_KEY} stated twice", line=number)
        found = diameter
    return found
