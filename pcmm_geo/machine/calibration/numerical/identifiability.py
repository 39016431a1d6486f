"""Identifiability of calibration parameters and pose selection (thesis 2.2.2.1, Verl et al. 2008).

The identification Jacobian ``J`` (residuals x parameters) tells which parameters the
data determine.  Its columns are first equilibrated (each scaled to unit norm) so the
result does not depend on the parameters' units (mm versus radians); then

* the singular values ``s_1 >= ... >= s_P`` and the condition number ``s_1 / s_P``
  (Verl's ``K_0``; 1 is ideal) measure how well-posed the identification is;
* the right singular vectors of the smallest singular values are the **parameter
  combinations the data cannot determine**: moving the parameters along such a vector
  changes the residuals by at most ``s_k`` (times the step), so noise moves them freely.
  They are reported by name (``"+0.71 d_a -0.70 b_ca"``).

:func:`select_poses` chooses measurement poses greedily, each time adding the candidate
that lowers the condition number most, then exchanges chosen poses for better ones
(steps 1-5 of thesis 2.2.2.1).

Examples
--------
>>> import numpy as np
>>> jac = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])  # only x + y is seen
>>> report = analyse_identifiability(jac, ("x", "y"))
>>> report.rank, report.weak_combinations[0].text
(1, '+0.707 x -0.707 y')
>>> {k: round(v, 3) for k, v in report.weak_combinations[0].parameter_direction.items()}
{'x': 0.707, 'y': -0.707}
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError

__all__ = ["Identifiability", "PoseSelection", "WeakCombination", "analyse_identifiability", "condition_number",
           "select_poses"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class WeakCombination:
    """A poorly determined direction in parameter space.

    Attributes
    ----------
    singular_value : float
        Of the column-equilibrated Jacobian.
    relative : float
        ``singular_value / s_max``.
    coefficients : dict
        Parameter name -> component of the (unit) right singular vector of the
        column-equilibrated Jacobian (each parameter measured in units of its own
        sensitivity).
    text : str
        Readable form of ``coefficients`` keeping components with ``|c| >= 0.1``.
    parameter_direction : dict
        The same direction in the parameters' own units (mm, rad), normalised to unit
        length: the step ``delta`` in parameter space that the data cannot see.
    """

    singular_value: float
    relative: float
    coefficients: dict[str, float]
    text: str
    parameter_direction: dict[str, float]


@record
class Identifiability:
    """Result of :func:`analyse_identifiability`.

    Attributes
    ----------
    names : tuple of str
    singular_values : ndarray, shape (P,)
        Column-equilibrated Jacobian, descending.
    condition_number : float
        ``s_max / s_min`` (inf when rank deficient).
    rank : int
        Number of singular values above ``tolerance * s_max``.
    column_norms : ndarray, shape (P,)
        Norms of the raw Jacobian columns (sensitivity of the residuals to each parameter).
    weak_combinations : tuple of WeakCombination
        Right singular vectors of the singular values below ``weak * s_max`` (at least the
        smallest one), weakest first.
    undetermined : tuple of str
        Texts of the combinations outside the numerical rank (not determined at all).
    """

    names: tuple[str, ...]
    singular_values: FloatArray
    condition_number: float
    rank: int
    column_norms: FloatArray
    weak_combinations: tuple[WeakCombination, ...]
    undetermined: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "names": list(self.names),
            "singular_values": self.singular_values.tolist(),
            "condition_number": self.condition_number if np.isfinite(self.condition_number) else None,
            "rank": self.rank,
            "column_norms": dict(zip(self.names, self.column_norms.tolist(), strict=True)),
            "weak_combinations": [
                {"singular_value": w.singular_value, "relative": w.relative, "text": w.text,
                 "parameter_direction": w.parameter_direction}
                for w in self.weak_combinations
            ],
            "undetermined": list(self.undetermined),
        }


def _orient(vector: FloatArray) -> FloatArray:
    """Sign convention: the first component with magnitude >= 0.1 is positive."""
    big = np.flatnonzero(np.abs(vector) >= 0.1)
    first = big[0] if big.size else int(np.argmax(np.abs(vector)))
    return -vector if vector[first] < 0 else vector


def _combination_text(vector: FloatArray, names: Sequence[str]) -> str:
    terms = [f"{c:+.3f} {name}" for c, name in zip(vector, names, strict=True) if abs(c) >= 0.1]
    return " ".join(terms)


def _equilibrate(jacobian: FloatArray) -> tuple[FloatArray, FloatArray]:
    norms = np.linalg.norm(jacobian, axis=0)
    safe = np.where(norms > 0, norms, 1.0)
    return jacobian / safe, norms


def condition_number(jacobian: ArrayLike) -> float:
    """Condition number of the column-equilibrated Jacobian (inf if rank deficient or a column is zero).

    Examples
    --------
    >>> condition_number(np.eye(3) * [1.0, 10.0, 100.0])
    1.0
    """
    jac = np.asarray(jacobian, dtype=float)
    scaled, norms = _equilibrate(jac)
    if np.any(norms == 0) or jac.shape[0] < jac.shape[1]:
        return float("inf")
    sing = np.linalg.svd(scaled, compute_uv=False)
    return float(sing[0] / sing[-1]) if sing[-1] > 1e-15 * sing[0] else float("inf")


def analyse_identifiability(
    jacobian: ArrayLike, names: Sequence[str], *, tolerance: float = 1e-10, weak: float = 1e-3
) -> Identifiability:
    """Singular-value analysis of an identification Jacobian.

    Parameters
    ----------
    jacobian : array_like, shape (M, P)
        Derivatives of the residuals with respect to the parameters.
    names : sequence of str, length P
        Parameter names.
    tolerance : float
        Relative singular value below which a direction counts as undetermined (rank).
    weak : float
        Relative singular value below which a direction is reported as weak.

    Returns
    -------
    Identifiability

    Raises
    ------
    InvalidInputError
        Not a finite 2-D array, or ``names`` of the wrong length.

    Examples
    --------
    See the module docstring.
    """
    jac = np.asarray(jacobian, dtype=float)
    if jac.ndim != 2 or not np.all(np.isfinite(jac)):
        raise InvalidInputError("jacobian", "a finite 2-D array (M, P)", f"shape {jac.shape}")
    if len(names) != jac.shape[1]:
        raise InvalidInputError("names", f"{jac.shape[1]} parameter names", f"{len(names)}")
    scaled, norms = _equilibrate(jac)
    _, sing, vt = np.linalg.svd(scaled, full_matrices=True)
    full = np.zeros(jac.shape[1])
    full[: sing.size] = sing
    top = full[0] if full[0] > 0 else 1.0
    rank = int(np.sum(full > tolerance * top))
    cond = float(full[0] / full[-1]) if full[-1] > tolerance * top else float("inf")
    weak_list = []
    for k in range(jac.shape[1] - 1, -1, -1):
        relative = full[k] / top
        if relative >= weak and weak_list:
            break
        vector = _orient(vt[k])
        raw = vector / np.where(norms > 0, norms, 1.0)
        raw = _orient(raw / np.linalg.norm(raw))
        weak_list.append(
            WeakCombination(
                singular_value=float(full[k]),
                relative=float(relative),
                coefficients=dict(zip(names, vector.tolist(), strict=True)),
                text=_combination_text(vector, names),
                parameter_direction=dict(zip(names, raw.tolist(), strict=True)),
            )
        )
    undetermined = tuple(w.text for w in weak_list if w.relative <= tolerance)
    return Identifiability(
        names=tuple(names),
        singular_values=full,
        condition_number=cond,
        rank=rank,
        column_norms=norms,
        weak_combinations=tuple(weak_list),
        undetermined=undetermined,
    )


@dataclass(frozen=True)
class PoseSelection:
    """Result of :func:`select_poses`: chosen candidate indices and the condition number after each addition."""

    indices: tuple[int, ...]
    condition_numbers: tuple[float, ...]
    final_condition_number: float


def _score(blocks: Sequence[FloatArray], chosen: Sequence[int]) -> tuple[float, float]:
    stacked = np.vstack([blocks[i] for i in chosen])
    cond = condition_number(stacked)
    scaled, _ = _equilibrate(stacked)
    sing = np.linalg.svd(scaled, compute_uv=False)
    # before full rank: prefer more (and larger) singular values (log-volume)
    volume = float(np.sum(np.log(sing[sing > 1e-12] + 1e-300)))
    return cond, -volume


def select_poses(
    candidates: Sequence[ArrayLike], count: int, *, initial: Sequence[int] = (), exchange_passes: int = 2
) -> PoseSelection:
    """Greedy pose selection minimising the condition number (Verl et al. 2008, thesis 2.2.2.1).

    Parameters
    ----------
    candidates : sequence of array_like, each shape (m_k, P)
        Identification-Jacobian rows of each candidate pose.
    count : int
        Number of poses to choose.
    initial : sequence of int
        Poses that must be kept.
    exchange_passes : int
        Passes of the exchange step (replace a chosen pose when another lowers the
        condition number), steps 3-4 of the thesis' list.

    Returns
    -------
    PoseSelection

    Raises
    ------
    InvalidInputError
        Inconsistent candidate shapes or ``count`` out of range.

    Examples
    --------
    >>> rows = [np.array([[1.0, 0.0]]), np.array([[1.0, 0.01]]), np.array([[0.0, 1.0]])]
    >>> select_poses(rows, 2).indices
    (0, 2)
    """
    blocks = [np.atleast_2d(np.asarray(c, dtype=float)) for c in candidates]
    widths = {b.shape[1] for b in blocks}
    if len(widths) != 1:
        raise InvalidInputError("candidates", "Jacobian blocks with the same number of columns", f"widths {widths}")
    if not 0 < count <= len(blocks) or len(initial) > count:
        raise InvalidInputError("count", f"1..{len(blocks)} and >= len(initial)", str(count))
    chosen = list(initial)
    history: list[float] = []
    while len(chosen) < count:
        best = min((i for i in range(len(blocks)) if i not in chosen), key=lambda i: _score(blocks, [*chosen, i]))
        chosen.append(best)
        history.append(_score(blocks, chosen)[0])
    for _ in range(exchange_passes):
        improved = False
        for slot in range(len(initial), len(chosen)):
            current = _score(blocks, chosen)
            for other in range(len(blocks)):
                if other in chosen:
                    continue
                trial = list(chosen)
                trial[slot] = other
                score = _score(blocks, trial)
                if score < current:
                    chosen, current, improved = trial, score, True
        if not improved:
            break
    return PoseSelection(tuple(chosen), tuple(history), _score(blocks, chosen)[0])
