"""The seed's own log processing (Appendix D): eqs 2.3-2.8 per laser pair, then the DPKM probe, for comparison.

:func:`process_log_dpkm` keeps the thesis' formulas (errata corrected) and tests nothing;
:func:`~pcmm_geo.machine.analysis.logproc.process_log` is the processing to use.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.analysis.logproc.process import ProcessedLog
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.kinematics.model import ARMS, as_readings

if TYPE_CHECKING:  # parameter_laws reads logs with this package's rows: imported where used
    from pcmm_geo.machine.analysis.parameter_laws import DpkmParameterLaws

__all__ = ["SEED_NEIGHBOUR", "process_log_dpkm"]


#: neighbour used by the seed to re-derive a moved pivot's height (Appendix D): a from c, b from a, c from b
SEED_NEIGHBOUR = {0: 2, 1: 0, 2: 1}


def process_log_dpkm(
    log: MeasurementLog,
    *,
    dead_distance: Mapping[str, float] | None = None,
    beta_deg: Mapping[str, float] | None = None,
    column_points: Mapping[str, ArrayLike],
    initial_heights: ArrayLike,
    sign_rule: str = "continuity",
    start_of_range: float = 60.0,
    parameter_laws: DpkmParameterLaws | None = None,
) -> ProcessedLog:
    """The seed's own processing: eqs 2.3-2.8 per laser pair, then eqs 2.9-2.18 (corrected).

    Row logic as in the module notes.  On each row the moved pivot ``i`` gets
    ``z_i = z_n +- |dz_in|`` from its seed neighbour ``n`` (a from c, b from a, c from b)
    with ``|dz|`` from eqs 2.5-2.8 and ``b`` the xy distance of the (vertical) columns.
    The probe is :func:`pcmm_geo.machine.kinematics.dpkm.dpkm_probe` of the pivots (the seed
    geometry: slider lines meeting at the tip, vertical columns).

    Parameters
    ----------
    log : MeasurementLog
    dead_distance, beta_deg : mapping
        ``d_i`` (mm, without the 60 mm start of range) and ``beta_in`` (degrees, "ab", "bc", "ca").
        Ignored when ``parameter_laws`` is given (pass ``None``).
    column_points : mapping arm -> (x, y)
        Vertical column positions (mm).
    initial_heights : array_like, shape (3,)
        Heights of the first row (the seed used ``z_a = 0``).
    sign_rule : {"continuity", "seed_direction"}
        ``"continuity"``: the sign giving the height nearest the previous one (correct while
        the pivot does not cross its neighbour's height); ``"seed_direction"``: the seed's
        rule, ``+`` when the row's direction is +1, ``-`` when -1 (continuity when 0).
    parameter_laws : DpkmParameterLaws, optional
        ``d_i`` and ``beta_in`` as laws of each row's lasers (thesis 8.2, variable parameters,
        :mod:`pcmm_geo.machine.analysis.parameter_laws`) instead of constants.

    Returns
    -------
    ProcessedLog
        ``residuals`` hold the b-c / c-a / a-b pair closure ``|z_j - z_k| - |dz_jk|`` (mm).
        Like the seed, this processing tests no row (``inconsistent`` all False, ``w_test``
        NaN) and propagates no uncertainty (NaN).

    Raises
    ------
    InvalidInputError
        Unknown ``sign_rule``.
    NoRealSolutionError
        A laser pair gives pivots closer than their column spacing, or the spheres miss.

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics import dpkm
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> from pcmm_geo.machine.analysis.logproc import synthesise_log
    >>> m = RigidBodyMachine.from_dpkm()
    >>> start = m.reference_heights + [0.0, 60.0, -50.0]
    >>> log = synthesise_log(m, start, [(1, 5.0, True)])
    >>> out = process_log_dpkm(log, dead_distance=dpkm.TABLE_3_1_DEAD_DISTANCE, beta_deg=dpkm.TABLE_3_1_BETA_DEG,
    ...                        column_points=dpkm.APPENDIX_D_COLUMN_POINTS, initial_heights=start)
    >>> bool(abs(out.heights[-1, 0] - start[0] - 5.0) < 1e-9)
    True
    """
    from pcmm_geo.machine.analysis.parameter_laws import DpkmParameterLaws
    from pcmm_geo.machine.kinematics.dpkm import arm_lengths, dpkm_probe, height_difference

    if sign_rule not in ("continuity", "seed_direction"):
        raise InvalidInputError("sign_rule", "'continuity' or 'seed_direction'", repr(sign_rule))
    if parameter_laws is None:
        if dead_distance is None or beta_deg is None:
            raise InvalidInputError("dead_distance/beta_deg", "mappings (or parameter_laws)", "None")
        parameter_laws = DpkmParameterLaws.constant(dead_distance, beta_deg)
    xy = np.array([np.asarray(column_points[arm], dtype=float)[:2] for arm in ARMS])
    dead_rows, beta_rows = parameter_laws.evaluate(log.lasers)
    lengths = arm_lengths(log.lasers, dict(zip(ARMS, np.zeros(3), strict=True)), start_of_range=start_of_range)
    lengths = lengths + dead_rows
    pair_column = {(0, 1): 0, (1, 2): 1, (2, 0): 2}  # columns of beta_rows: ab, bc, ca

    def dz(row: int, i: int, j: int) -> float:
        key = (i, j) if (i, j) in pair_column else (j, i)
        beta = np.radians(beta_rows[row, pair_column[key]])
        return float(height_difference(lengths[row, i], lengths[row, j], beta, np.linalg.norm(xy[i] - xy[j])))

    count = len(log)
    heights = np.empty((count, 3))
    moved = np.full(count, -1, dtype=np.int64)
    consistent = np.ones(count, dtype=bool)
    heights[0] = as_readings(initial_heights, "initial_heights")
    for row in range(1, count):
        heights[row] = heights[row - 1]
        if log.start_stop[row] == 1 and np.array_equal(log.lasers[row], log.lasers[row - 1]):
            continue
        stop = log.start_stop[row] == 0
        arm = int(log.motor[row] if stop else log.motor[row - 1]) - 1
        direction = int(log.direction[row] if stop else log.direction[row - 1])
        moved[row] = arm
        neighbour = SEED_NEIGHBOUR[arm]
        size = dz(row, arm, neighbour)
        above, below = heights[row, neighbour] + size, heights[row, neighbour] - size
        nearest = above if abs(above - heights[row - 1, arm]) <= abs(below - heights[row - 1, arm]) else below
        if sign_rule == "seed_direction" and direction != 0:
            heights[row, arm] = above if direction > 0 else below
        else:
            heights[row, arm] = nearest
        change = heights[row, arm] - heights[row - 1, arm]
        consistent[row] = direction == 0 or abs(change) <= 1e-3 or np.sign(change) == direction
    pivots = np.concatenate([np.broadcast_to(xy, (count, 3, 2)), heights[..., None]], axis=-1)
    tips = dpkm_probe(pivots, lengths).point
    residuals = np.zeros((count, 3))
    for k, (i, j) in enumerate(((1, 2), (2, 0), (0, 1))):
        residuals[:, k] = [abs(heights[r, i] - heights[r, j]) - dz(r, i, j) for r in range(count)]
    probe_rows = np.flatnonzero(log.probe == 1)
    untested, nothing = np.full((count, 3), np.nan), np.zeros(count, dtype=bool)
    return ProcessedLog(  # the seed's processing tests nothing and propagates no uncertainty
        heights=heights, tips=tips, probe_rows=probe_rows, probe_points=tips[probe_rows],
        rejected_probe_rows=np.zeros(0, dtype=np.int64), moved_arm=moved, residuals=residuals,
        closure_residual=np.linalg.norm(residuals, axis=1), w_test=untested, redundancy=untested, mdb=untested,
        faulty_readings=np.zeros((count, 3), dtype=bool), inconsistent=nothing, converged=~nothing,
        direction_consistent=consistent, tip_covariance=np.full((count, 3, 3), np.nan),
        tip_uncertainty=np.full(count, np.nan), tip_reliability=np.full(count, np.nan), ambiguous=nothing,
        ambiguity=np.zeros(count), uncertain=nothing, over_bound=nothing, max_tip_uncertainty=float("inf"),
        max_bound=float("inf"), alpha=float("nan"), power=float("nan"), critical_value=float("nan"),
        closure_tolerance=None, laser_sigmas=np.full(3, np.nan), calibration_included=False,
    )
