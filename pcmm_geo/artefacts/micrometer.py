"""Micrometer-stage test of the micro-CMM (thesis sections 8.1-8.2, Table 8.1).

A three-axis micrometer stage (the thesis used one with 0.01 mm accuracy) carries a
v-block; the probe tip is moved to a sequence of points and each position is read both from
the stage (reference) and from the CMM (computed).  Distances between points are invariant
to how the stage axes are aligned with the machine axes, so the test compares, for each
pair of points, the distance travelled according to the stage with the distance according to
the CMM:

``error = |p_j − p_i| (CMM) − |s_j − s_i| (stage)``.

The thesis reports consecutive pairs (1-2, 2-3, 3-4) and the accumulated pairs from the
first point (1-3, 1-4); ``pairs="thesis"`` reproduces that choice, ``"consecutive"`` and
``"all"`` are also offered.  Table 8.1's "Measured" row is the stage distance, "Calculated"
the CMM distance.

CSV input (:func:`read_micrometer_csv`): header ``point,stage_x,stage_y,stage_z,x,y,z`` (mm).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.artefacts.table import cell_float, cell_text, read_rows
from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.fit import as_points

__all__ = ["PairError", "StageTestResult", "evaluate_stage_test", "read_micrometer_csv", "stage_pairs"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PairError:
    """Distance between two points by stage and by CMM (mm); indices are 0-based."""

    first: int
    second: int
    label: str
    stage_distance: float
    cmm_distance: float
    error: float


@dataclass(frozen=True)
class StageTestResult:
    """Micrometer-stage test result.

    Attributes
    ----------
    pairs : tuple of PairError
    max_abs_error : float
        mm.
    rms_error : float
        mm.
    labels : tuple of str
        Point labels (1-based numbers by default).
    """

    pairs: tuple[PairError, ...]
    max_abs_error: float
    rms_error: float
    labels: tuple[str, ...]


def stage_pairs(n_points: int, pairs: str = "thesis") -> list[tuple[int, int]]:
    """Index pairs evaluated for ``n_points`` points.

    ``"thesis"``: consecutive pairs then the first point with every later non-adjacent point
    (for 4 points: 1-2, 2-3, 3-4, 1-3, 1-4); ``"consecutive"``; ``"all"`` (every pair).

    Raises
    ------
    InvalidInputError
        Fewer than 2 points or an unknown choice.

    Examples
    --------
    >>> stage_pairs(4)
    [(0, 1), (1, 2), (2, 3), (0, 2), (0, 3)]
    """
    if n_points < 2:
        raise InvalidInputError("points", "at least 2 points", f"{n_points}")
    consecutive = [(i, i + 1) for i in range(n_points - 1)]
    if pairs == "consecutive":
        return consecutive
    if pairs == "thesis":
        return consecutive + [(0, j) for j in range(2, n_points)]
    if pairs == "all":
        return list(itertools.combinations(range(n_points), 2))
    raise InvalidInputError("pairs", "one of 'thesis', 'consecutive', 'all'", repr(pairs))


def evaluate_stage_test(
    stage_positions: ArrayLike,
    cmm_points: ArrayLike,
    *,
    pairs: str = "thesis",
    labels: tuple[str, ...] | None = None,
) -> StageTestResult:
    """Compare CMM distances with micrometer-stage distances for pairs of probe positions.

    Parameters
    ----------
    stage_positions : array_like, shape (N, 3)
        Stage readings of each position (mm), in the stage's own axes.
    cmm_points : array_like, shape (N, 3)
        Tip positions computed by the CMM (mm).
    pairs : {"thesis", "consecutive", "all"}
        Which pairs to evaluate (:func:`stage_pairs`).
    labels : tuple of str, optional
        Point names; default "1", "2", ...

    Returns
    -------
    StageTestResult

    Raises
    ------
    InvalidInputError
        Mismatched shapes, fewer than 2 points, wrong number of labels.

    Examples
    --------
    >>> stage = [[0, 0, 0], [10, 0, 0], [10, 5, 0]]
    >>> cmm = [[0, 0, 0], [10.02, 0, 0], [10.02, 5.01, 0]]
    >>> [round(p.error, 6) for p in evaluate_stage_test(stage, cmm).pairs]
    [0.02, 0.01, 0.022361]
    """
    stage = as_points(stage_positions, element="micrometer stage test", min_points=2, name="stage_positions")
    cmm = as_points(cmm_points, element="micrometer stage test", min_points=2, name="cmm_points")
    if stage.shape != cmm.shape:
        raise InvalidInputError("cmm_points", f"shape {stage.shape} like stage_positions", f"shape {cmm.shape}")
    names = tuple(str(i + 1) for i in range(len(stage))) if labels is None else tuple(labels)
    if len(names) != len(stage):
        raise InvalidInputError("labels", f"{len(stage)} labels", f"{len(names)}")
    out = []
    for i, j in stage_pairs(len(stage), pairs):
        ds = float(np.linalg.norm(stage[j] - stage[i]))
        dc = float(np.linalg.norm(cmm[j] - cmm[i]))
        out.append(PairError(i, j, f"{names[i]}-{names[j]}", ds, dc, dc - ds))
    errors = np.array([p.error for p in out])
    return StageTestResult(
        pairs=tuple(out),
        max_abs_error=float(np.abs(errors).max()),
        rms_error=float(np.sqrt(np.mean(errors**2))),
        labels=names,
    )


def read_micrometer_csv(path: str | Path) -> tuple[FloatArray, FloatArray, tuple[str, ...]]:
    """Read ``point,stage_x,stage_y,stage_z,x,y,z`` rows -> (stage (N,3), cmm (N,3), labels).

    Raises
    ------
    FileFormatError
        Missing columns, bad numbers, duplicate point labels, fewer than 2 rows.
    OSError
        Unreadable file.

    Examples
    --------
    >>> from importlib.resources import files
    >>> stage, cmm, labels = read_micrometer_csv(files("pcmm_geo") / "data/examples/micrometer_stage.csv")
    >>> stage.shape, labels
    ((4, 3), ('1', '2', '3', '4'))
    """
    columns = ("point", "stage_x", "stage_y", "stage_z", "x", "y", "z")
    rows = read_rows(path, columns)
    labels = tuple(cell_text(path, line, row, "point") for line, row in rows)
    if len(set(labels)) != len(labels):
        raise FileFormatError(str(path), "point labels must be unique")
    if len(rows) < 2:
        raise FileFormatError(str(path), f"expected at least 2 points, got {len(rows)}")
    stage = np.array([[cell_float(path, line, row, f"stage_{a}") for a in "xyz"] for line, row in rows])
    cmm = np.array([[cell_float(path, line, row, a) for a in "xyz"] for line, row in rows])
    return stage, cmm, labels
