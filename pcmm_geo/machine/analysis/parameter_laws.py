"""Variable machine parameters of the seed's DPKM: ``d_i`` and ``beta_in`` as linear laws of the lasers (thesis 8.2).

Why the seed's parameters vary (thesis 7.2)
-------------------------------------------
The DPKM assumes that the three slider lines meet at the probe tip, so that the
pivot-to-tip length of arm ``i`` is ``L_i = l_i + 60 + d_i`` with a constant dead distance
``d_i`` and constant angles ``beta_in`` between the arms.  The calibrated tetrahedron's
slider lines miss the tip: the distance from the tip to a joint then grows
*nonlinearly* with the laser reading, and the angle between two tip-to-joint vectors
changes with both readings.  The thesis (Table 7.1) took averages; in section 8.2 it made
``d_i``, ``beta_in`` and ``b_in`` linear functions of "the laser distance" and processed
the micrometer-stage (3MS) log with them, and the errors grew (Table 8.2).  Appendix C
(lines 81-144) shows how the laws were made: a straight line through the values at the
two calibration positions, ``d_i`` against laser ``i`` and ``beta_ca``, ``beta_ab``,
``beta_bc`` against lasers a, b, c (:data:`THESIS_BETA_DRIVERS`).

What this module does
---------------------
* :func:`parameter_samples`: ``d_i`` and ``beta_in`` at each calibration position from the
  joint centers, the tip and the lasers (Appendix C's computation).
* :func:`fit_parameter_laws`: least-squares laws through ``K`` positions (the thesis'
  two-point lines when ``K = 2``) and the constant model (their means), with the RMS of
  what a law leaves (the nonlinearity).  Angles may be driven by one reading
  (:data:`THESIS_BETA_DRIVERS`) or by both arms' readings (:data:`BOTH_ARMS_BETA_DRIVERS`).
* :class:`DpkmParameterLaws` evaluates the laws per log row; pass it to
  :func:`pcmm_geo.machine.analysis.logproc.process_log_dpkm` (``parameter_laws=``).
* :func:`synthesise_log_dpkm`: a noise-free log of a DPKM machine whose parameters follow
  given laws (constant or variable), the constructed truth of the tests.

What the tests find (``tests/machine/test_parameter_laws.py``)
--------------------------------------------------------------
* ``d_i`` depends on laser ``i`` only and bends little: along the rebuilt Appendix C/D
  slider lines a straight line leaves 2-9 um RMS.  ``beta_in`` changes with *both*
  readings (about 0.011 degree per mm of ``l_a`` for ``beta_ab``, which Appendix C drives
  by ``l_b``): a one-reading law learnt from positions where all arms moved together
  is wrong as soon as the arms move differently, as they do in a log.
* On a rigid tetrahedron whose slider lines miss the tip by 3-6 mm, the DPKM with the
  thesis' two-position laws puts the tip 7.7 mm off where the constants give 2.6 mm -- the
  direction of Table 8.2.  Laws driven by both arms and fitted over the log's range give
  0.007 mm; the rigid-body model, which places the lines where they are, is exact.

``b_in`` gets no law: here it is the xy spacing of the column lines, which no laser
changes (the seed's ``b_in``, Appendix D, is the smallest eq 7.5 value over a log, a
stand-in against complex roots); a law for it would need the 7.2 sweep, not printed.

Table 8.2 cannot be recomputed: the 3MS laser log (``micro1m.csv``) is not printed.
:data:`TABLE_8_1` and :data:`TABLE_8_2` hold the printed rows; their "Error" rows are
``Calculated - Measured`` to the printed 0.01 mm (:func:`table_8_errors`).

Examples
--------
>>> laws = DpkmParameterLaws.constant({"a": 314.48, "b": 312.74, "c": 309.42},
...                                   {"ab": 68.25, "bc": 69.03, "ca": 68.70})
>>> dead, beta = laws.evaluate([[50.0, 60.0, 70.0]])
>>> dead.tolist(), laws.is_constant
([[314.48, 312.74, 309.42]], True)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import ConvergenceError, InvalidInputError
from pcmm_geo.fit.skew import angle_between
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.kinematics.dpkm import PAIRS, START_OF_RANGE
from pcmm_geo.machine.kinematics.model_parts import ARMS, as_readings, check_arm_keys

__all__ = [
    "TABLE_8_1",
    "TABLE_8_2",
    "BOTH_ARMS_BETA_DRIVERS",
    "THESIS_BETA_DRIVERS",
    "DpkmParameterLaws",
    "LinearLaw",
    "ParameterLawFit",
    "fit_parameter_laws",
    "parameter_samples",
    "synthesise_log_dpkm",
    "table_8_errors",
]

FloatArray = NDArray[np.float64]

#: laser that drives each angle law in Appendix C (lines 134-144): beta_ab on l_b, beta_bc on l_c, beta_ca on l_a
THESIS_BETA_DRIVERS: Mapping[str, tuple[str, ...]] = {"ab": ("b",), "bc": ("c",), "ca": ("a",)}
#: each angle driven by the readings of both its arms (needs positions where the two move independently)
BOTH_ARMS_BETA_DRIVERS: Mapping[str, tuple[str, ...]] = {"ab": ("a", "b"), "bc": ("b", "c"), "ca": ("c", "a")}

#: Table 8.1 (3MS test, constant parameters): pair -> (Measured, Calculated, Error), mm
TABLE_8_1 = {
    "1-2": (19.11, 20.72, 1.61), "2-3": (8.69, 11.28, 2.59), "3-4": (8.11, 8.37, 0.27),
    "1-3": (27.76, 31.55, 3.78), "1-4": (35.87, 39.59, 3.73),
}
#: Table 8.2 (the same test, variable parameters): pair -> (Calculated, Error), mm; "Measured" is Table 8.1's
TABLE_8_2 = {
    "1-2": (21.03, 1.92), "2-3": (12.15, 3.45), "3-4": (8.96, 0.85), "1-3": (32.69, 4.92), "1-4": (41.38, 5.51),
}


@dataclass(frozen=True)
class LinearLaw:
    """``value = intercept + sum(slopes[arm] * laser[arm])`` (mm or degrees; slopes per mm of reading).

    The thesis' laws have one driving laser (``slopes={"b": -0.0023}``); an angle between two
    arms is better driven by both readings (:data:`BOTH_ARMS_BETA_DRIVERS`).  No slopes: a constant.

    Examples
    --------
    >>> law = LinearLaw(68.0, {"a": 0.01, "b": -0.02})
    >>> round(float(law([10.0, 20.0, 30.0])), 6), law.drivers
    (67.7, ('a', 'b'))
    """

    intercept: float
    slopes: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not set(self.slopes) <= set(ARMS):
            raise InvalidInputError("slopes", "a mapping with keys among 'a', 'b', 'c'", repr(sorted(self.slopes)))
        values = {"intercept": float(self.intercept)} | {f"slopes[{k}]": float(v) for k, v in self.slopes.items()}
        for name, value in values.items():
            if not np.isfinite(value):
                raise InvalidInputError(name, "a finite number", str(value))
        object.__setattr__(self, "intercept", float(self.intercept))
        object.__setattr__(self, "slopes", {arm: float(self.slopes[arm]) for arm in ARMS if arm in self.slopes})

    @property
    def drivers(self) -> tuple[str, ...]:
        """Arms whose readings drive the law, in order a, b, c."""
        return tuple(self.slopes)

    def __call__(self, lasers: ArrayLike) -> FloatArray:
        """Values for laser readings ``(..., 3)`` -> ``(...)``."""
        readings = as_readings(lasers, "lasers")
        value = np.full(readings.shape[:-1], self.intercept)
        for arm, slope in self.slopes.items():
            value = value + slope * readings[..., ARMS.index(arm)]
        return value


@dataclass(frozen=True)
class DpkmParameterLaws:
    """Dead distances (mm, without the 60 mm start of range) and arm angles (degrees) as laws of the lasers.

    Attributes
    ----------
    dead_distance : mapping arm -> LinearLaw
        ``d_i``; the thesis drives each by its own laser.
    beta_deg : mapping pair -> LinearLaw
        ``beta_ab``, ``beta_bc``, ``beta_ca`` in degrees.
    """

    dead_distance: Mapping[str, LinearLaw]
    beta_deg: Mapping[str, LinearLaw]

    def __post_init__(self) -> None:
        check_arm_keys(self.dead_distance, "dead_distance")
        if set(self.beta_deg) != set(PAIRS):
            raise InvalidInputError("beta_deg", f"keys {PAIRS}", repr(sorted(self.beta_deg)))
        object.__setattr__(self, "dead_distance", {arm: self.dead_distance[arm] for arm in ARMS})
        object.__setattr__(self, "beta_deg", {pair: self.beta_deg[pair] for pair in PAIRS})

    @classmethod
    def constant(cls, dead_distance: Mapping[str, float], beta_deg: Mapping[str, float]) -> DpkmParameterLaws:
        """Laws with zero slope: the usual constant parameters (Table 3.1 / 7.1 style)."""
        return cls(
            {arm: LinearLaw(float(dead_distance[arm])) for arm in ARMS},
            {pair: LinearLaw(float(beta_deg[pair])) for pair in PAIRS},
        )

    @classmethod
    def from_calibration(cls, calibration: Any, *, variable: bool = True) -> DpkmParameterLaws:
        """Laws from a :class:`~pcmm_geo.machine.calibration.TetrahedronCalibration` (thesis 7.3 / Appendix C).

        ``variable=True``: its ``dead_distance_linear`` and ``beta_linear`` (Appendix C's drivers,
        beta in radians there, degrees here); ``False``: its means ``dead_distance`` and
        ``beta_deg`` (Table 7.1).  Any object with those attributes will do.

        Raises
        ------
        InvalidInputError
            The object lacks the attributes.
        """
        try:
            if not variable:
                return cls.constant(calibration.dead_distance, calibration.beta_deg)
            dead = {arm: LinearLaw(intercept, {arm: slope})
                    for arm, (slope, intercept) in calibration.dead_distance_linear.items()}
            beta = {pair: LinearLaw(float(np.degrees(intercept)),
                                    {THESIS_BETA_DRIVERS[pair][0]: float(np.degrees(slope))})
                    for pair, (slope, intercept) in calibration.beta_linear.items()}
        except (AttributeError, TypeError, ValueError) as exc:
            raise InvalidInputError("calibration", "a TetrahedronCalibration (dead_distance_linear, beta_linear)",
                                    repr(exc)) from None
        return cls(dead, beta)

    @property
    def is_constant(self) -> bool:
        """True when every slope is zero."""
        laws = (*self.dead_distance.values(), *self.beta_deg.values())
        return all(slope == 0.0 for law in laws for slope in law.slopes.values())

    def at(self, lasers: ArrayLike) -> DpkmParameterLaws:
        """The constant laws with the values at one set of readings ``(3,)`` (e.g. a mid-range pose)."""
        dead, beta = self.evaluate(np.asarray(lasers, dtype=float).reshape(1, 3))
        return DpkmParameterLaws.constant(dict(zip(ARMS, dead[0], strict=True)), dict(zip(PAIRS, beta[0], strict=True)))

    def evaluate(self, lasers: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """``(dead_distance, beta_deg)``, each ``(..., 3)`` (arms a, b, c; pairs ab, bc, ca) for lasers ``(..., 3)``."""
        readings = as_readings(lasers, "lasers")
        dead = np.stack([self.dead_distance[arm](readings) for arm in ARMS], axis=-1)
        beta = np.stack([self.beta_deg[pair](readings) for pair in PAIRS], axis=-1)
        return dead, beta


@record
class ParameterLawFit:
    """Result of :func:`fit_parameter_laws`.

    Attributes
    ----------
    laws : DpkmParameterLaws
        Straight lines through the samples (least squares; exact through two positions).
    constant : DpkmParameterLaws
        The mean of the samples (the thesis' averages).
    lasers : ndarray, shape (K, 3)
    dead_distance, beta_deg : ndarray, shape (K, 3)
        Samples at each position (mm; degrees, pairs ab, bc, ca).
    dead_distance_nonlinearity, beta_nonlinearity : ndarray, shape (3,)
        RMS of what the fitted law leaves per arm / pair (mm; degrees); zero when the
        positions are as many as the law's coefficients.
    """

    laws: DpkmParameterLaws
    constant: DpkmParameterLaws
    lasers: FloatArray
    dead_distance: FloatArray
    beta_deg: FloatArray
    dead_distance_nonlinearity: FloatArray
    beta_nonlinearity: FloatArray


def parameter_samples(
    joints: ArrayLike, tip: ArrayLike, lasers: ArrayLike, *, start_of_range: float = START_OF_RANGE
) -> tuple[FloatArray, FloatArray]:
    """Dead distances and arm angles seen from ``tip`` at each calibration position (Appendix C lines 81-131).

    ``d_ik = |J_ik - tip| - l_ik - start_of_range``; ``beta_in,k`` is the angle between the
    tip-to-joint vectors of arms ``i`` and ``n`` (degrees).

    Parameters
    ----------
    joints : array_like, shape (K, 3, 3)
        Joint (sphere) centers per position, arms a, b, c (mm, any frame).
    tip : array_like, shape (3,)
        Probe-tip center in the same frame (or the theoretical probe point of eq 7.2).
    lasers : array_like, shape (K, 3)
        Laser readings at each position (mm).

    Returns
    -------
    dead_distance, beta_deg : ndarray, shape (K, 3)

    Raises
    ------
    InvalidInputError
        Wrong shapes or non-finite values.

    Examples
    --------
    >>> joints = [[[0.0, 0.0, 400.0], [400.0, 0.0, 0.0], [0.0, 400.0, 0.0]]]
    >>> dead, beta = parameter_samples(joints, [0.0, 0.0, 0.0], [[40.0, 40.0, 40.0]])
    >>> dead.tolist(), np.round(beta, 6).tolist()
    ([[300.0, 300.0, 300.0]], [[90.0, 90.0, 90.0]])
    """
    centers = np.asarray(joints, dtype=float)
    readings = np.asarray(lasers, dtype=float)
    origin = np.asarray(tip, dtype=float)
    if centers.ndim != 3 or centers.shape[1:] != (3, 3) or readings.shape != centers.shape[:2] or origin.shape != (3,):
        raise InvalidInputError("joints/tip/lasers", "shapes (K, 3, 3), (3,), (K, 3)",
                                f"{centers.shape}, {origin.shape}, {readings.shape}")
    if not (np.isfinite(centers).all() and np.isfinite(readings).all() and np.isfinite(origin).all()):
        raise InvalidInputError("joints/tip/lasers", "finite values", "NaN or inf")
    vectors = centers - origin
    lengths = np.linalg.norm(vectors, axis=-1)
    dead = lengths - readings - start_of_range
    beta = np.empty_like(dead)
    for k, (i, n) in enumerate(PAIRS):
        beta[:, k] = np.degrees(angle_between(vectors[:, ARMS.index(i)], vectors[:, ARMS.index(n)]))
    return dead, beta


def fit_parameter_laws(
    joints: ArrayLike,
    tip: ArrayLike,
    lasers: ArrayLike,
    *,
    beta_drivers: Mapping[str, Sequence[str]] = THESIS_BETA_DRIVERS,
    start_of_range: float = START_OF_RANGE,
) -> ParameterLawFit:
    """Linear laws ``d_i(l_i)`` and ``beta_in(l_drivers)`` from calibration positions (thesis 8.2, Appendix C).

    Each law is a least-squares plane in its driving readings (a straight line for one
    driver, exact through two positions: the thesis' construction).  ``d_i`` is driven by
    laser ``i`` alone: the distance from the tip to joint ``i`` depends on no other reading.

    Parameters
    ----------
    joints : array_like, shape (K, 3, 3)
        Joint centers at ``K`` positions (mm).
    tip : array_like, shape (3,)
    lasers : array_like, shape (K, 3)
    beta_drivers : mapping pair -> sequence of arms
        Which readings drive each angle law.  Appendix C (:data:`THESIS_BETA_DRIVERS`) drives
        each angle by one reading; an angle between two arms depends on both
        (:data:`BOTH_ARMS_BETA_DRIVERS`), which needs positions where the two readings do not
        move in proportion (the seed's two positions moved all arms together).

    Returns
    -------
    ParameterLawFit

    Raises
    ------
    InvalidInputError
        Bad shapes or drivers, or positions that cannot separate a law's drivers (fewer
        positions than coefficients, or driving readings that move in proportion).

    Examples
    --------
    >>> joints = [[[0.0, 0.0, 400.0], [400.0, 0.0, 0.0], [0.0, 400.0, 0.0]],
    ...           [[0.0, 0.0, 350.0], [351.0, 0.0, 0.0], [0.0, 352.0, 0.0]]]
    >>> fit = fit_parameter_laws(joints, [0.0, 0.0, 0.0], [[40.0, 40.0, 40.0], [0.0, 0.0, 0.0]])
    >>> [round(fit.laws.dead_distance[arm].slopes[arm], 6) for arm in "abc"]
    [0.25, 0.225, 0.2]
    """
    dead, beta = parameter_samples(joints, tip, lasers, start_of_range=start_of_range)
    readings = np.asarray(lasers, dtype=float)
    drivers = {pair: tuple(beta_drivers.get(pair, ())) for pair in PAIRS}
    if set(beta_drivers) != set(PAIRS) or not all(d and set(d) <= set(ARMS) for d in drivers.values()):
        raise InvalidInputError("beta_drivers", "a mapping of 'ab', 'bc', 'ca' to arms", repr(dict(beta_drivers)))

    def plane(values: FloatArray, arms: tuple[str, ...], what: str) -> tuple[LinearLaw, float]:
        x = readings[:, [ARMS.index(arm) for arm in arms]]
        centre = x.mean(axis=0)
        design = np.column_stack([np.ones(len(x)), x - centre])  # centred: well conditioned
        if len(x) < design.shape[1] or np.linalg.matrix_rank(design, tol=1e-9 * max(1.0, np.abs(x).max())) < \
                design.shape[1]:
            raise InvalidInputError(
                f"calibration positions for {what}", f"readings of {', '.join(arms)} that vary independently "
                f"at {design.shape[1]} or more positions", f"{len(x)} positions of rank "
                f"{np.linalg.matrix_rank(design)}")
        coefficients, *_ = np.linalg.lstsq(design, values, rcond=None)
        left = values - design @ coefficients
        slopes = dict(zip(arms, coefficients[1:], strict=True))
        law = LinearLaw(float(coefficients[0] - coefficients[1:] @ centre), slopes)
        return law, float(np.sqrt(np.mean(left**2)))

    dead_fits = [plane(dead[:, k], (arm,), f"d_{arm}") for k, arm in enumerate(ARMS)]
    beta_fits = [plane(beta[:, k], drivers[pair], f"beta_{pair}") for k, pair in enumerate(PAIRS)]
    laws = DpkmParameterLaws(
        {arm: fit for arm, (fit, _) in zip(ARMS, dead_fits, strict=True)},
        {pair: fit for pair, (fit, _) in zip(PAIRS, beta_fits, strict=True)},
    )
    constant = DpkmParameterLaws.constant(dict(zip(ARMS, dead.mean(axis=0), strict=True)),
                                          dict(zip(PAIRS, beta.mean(axis=0), strict=True)))
    return ParameterLawFit(
        laws=laws, constant=constant, lasers=readings, dead_distance=dead, beta_deg=beta,
        dead_distance_nonlinearity=np.array([rms for _, rms in dead_fits]),
        beta_nonlinearity=np.array([rms for _, rms in beta_fits]),
    )


def synthesise_log_dpkm(
    laws: DpkmParameterLaws,
    column_points: Mapping[str, ArrayLike],
    initial_heights: ArrayLike,
    moves: Sequence[tuple[int, float, bool]],
    *,
    start_of_range: float = START_OF_RANGE,
    lasers_hint: ArrayLike | None = None,
) -> tuple[MeasurementLog, FloatArray, FloatArray]:
    """Noise-free log of a DPKM machine (vertical columns) whose ``d_i`` and ``beta_in`` follow ``laws``.

    For each state the three lasers solve the pair equations (eqs 2.7-2.8 with the laws)
    ``|P_i - P_n|^2 = L_i^2 + L_n^2 - 2 L_i L_n cos(beta_in(l))``, ``L_i = l_i + 60 + d_i(l_i)``,
    by Newton's method; the tip is the lower intersection of the three spheres (eq 2.10).
    Rows as in :func:`pcmm_geo.machine.analysis.logproc.synthesise_log`.

    Parameters
    ----------
    laws : DpkmParameterLaws
    column_points : mapping arm -> (x, y)
        Vertical column positions (mm).
    initial_heights : array_like, shape (3,)
    moves : sequence of (motor, height_change, probe)
    lasers_hint : array_like, shape (3,), optional
        Starting lasers of the first state (default 100 mm each).

    Returns
    -------
    log : MeasurementLog
    heights : ndarray, shape (N, 3)
        Pivot heights of each row (mm).
    tips : ndarray, shape (N, 3)
        True probe-tip centers (mm).

    Raises
    ------
    ConvergenceError
        A state has no laser solution near the previous one.

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics import dpkm
    >>> laws = DpkmParameterLaws.constant(dpkm.TABLE_3_1_DEAD_DISTANCE, dpkm.TABLE_3_1_BETA_DEG)
    >>> log, heights, tips = synthesise_log_dpkm(laws, dpkm.APPENDIX_D_COLUMN_POINTS, [400.0, 460.0, 350.0],
    ...                                          [(1, 5.0, True)])
    >>> len(log), heights[-1].tolist()
    (2, [405.0, 460.0, 350.0])
    """
    from pcmm_geo.machine.kinematics.dpkm import dpkm_probe

    xy = np.array([np.asarray(column_points[arm], dtype=float)[:2] for arm in ARMS])
    states = [as_readings(initial_heights, "initial_heights").astype(float)]
    flags = []
    for motor, change, touching in moves:
        if motor not in (1, 2, 3):
            raise InvalidInputError("motor", "1, 2 or 3", repr(motor))
        direction = int(np.sign(change))
        after = states[-1].copy()
        after[motor - 1] += change
        flags += [(1, 0, motor, direction), (0, int(bool(touching)), motor, direction)]
        states += [states[-1], after]
    heights = np.array(states[1:])
    lasers = np.empty_like(heights)
    guess = np.full(3, 100.0) if lasers_hint is None else as_readings(lasers_hint, "lasers_hint").astype(float)
    for row, state in enumerate(heights):
        lasers[row] = guess = _solve_lasers(laws, xy, state, guess, start_of_range)
    pivots = np.concatenate([np.broadcast_to(xy, (len(heights), 3, 2)), heights[..., None]], axis=-1)
    dead, _ = laws.evaluate(lasers)
    tips = dpkm_probe(pivots, lasers + start_of_range + dead).point
    table = np.array(flags, dtype=np.int64).reshape(-1, 4)
    return MeasurementLog(table[:, 0], table[:, 1], table[:, 2], table[:, 3], lasers), heights, tips


def _solve_lasers(
    laws: DpkmParameterLaws, xy: FloatArray, heights: FloatArray, guess: FloatArray, start_of_range: float
) -> FloatArray:
    """Lasers ``(3,)`` meeting the three pair equations for pivot ``heights`` (Newton, numerical Jacobian)."""
    index = [(ARMS.index(i), ARMS.index(n)) for i, n in PAIRS]
    target = np.array([np.sum((xy[i] - xy[n]) ** 2) + (heights[i] - heights[n]) ** 2 for i, n in index])

    def pair_equations(readings: FloatArray) -> FloatArray:
        dead, beta = laws.evaluate(readings[None])
        length = readings + start_of_range + dead[0]
        cosine = np.cos(np.radians(beta[0]))
        modelled = np.array([length[i] ** 2 + length[n] ** 2 - 2 * length[i] * length[n] * cosine[k]
                             for k, (i, n) in enumerate(index)])
        return modelled - target

    readings = guess.copy()
    for iteration in range(1, 51):  # noqa: B007 (reported in the error)
        value = pair_equations(readings)
        step_size = 1e-6
        jacobian = np.column_stack([(pair_equations(readings + step_size * e) - value) / step_size for e in np.eye(3)])
        step = np.linalg.solve(jacobian, -value)
        readings = readings + step
        if np.abs(step).max() < 1e-12 * max(1.0, np.abs(readings).max()):
            return readings
    raise ConvergenceError("DPKM lasers for given heights", iteration, f"last step {np.abs(step).max():.3g} mm")


def table_8_errors() -> dict[str, tuple[float, float]]:
    """``Calculated - Measured`` of Tables 8.1 and 8.2 from their printed rows: pair -> (8.1, 8.2), mm.

    Both tables' "Measured" is Table 8.1's stage distance.  The recomputed errors agree with
    the printed "Error" rows to their last digit (0.01 mm) or within one unit of it, as
    rounding the printed inputs allows.

    Examples
    --------
    >>> {pair: tuple(round(e, 2) for e in errors) for pair, errors in table_8_errors().items()}["2-3"]
    (2.59, 3.46)
    """
    return {
        pair: (TABLE_8_1[pair][1] - TABLE_8_1[pair][0], TABLE_8_2[pair][0] - TABLE_8_1[pair][0]) for pair in TABLE_8_1
    }
