"""Passes over many points in cache-sized chunks: moments and Gauss-Newton normal equations.

A *pass* applies a kernel to consecutive chunks of ``CHUNK_ROWS`` rows and adds up what
each chunk returns (:class:`Sums`: sums, plus running minima and maxima).  Nothing of the
size of the data is allocated except, on request, the residuals written into an output
array.  The same kernels run on the blocks of a dask array (:mod:`pcmm_geo.fit.scale.dask`),
so in-memory and out-of-core fits share one implementation.

Conditioning: coordinates are taken relative to a *shift*, a point of the data (the first
row), before any product is formed, so that a cloud 1000 mm from the origin is summed
like one at the origin (the centred scatter ``S - n m m^T`` then loses digits only to the
size of the cloud, not to its offset).  Gauss-Newton steps solve the column-scaled
normal equations; the fixed point ``J^T r = 0`` they converge to is accumulated directly,
so its accuracy does not depend on how accurately each step is solved.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import ConvergenceError
from pcmm_geo.fit._kernels._core import TOL

FloatArray = NDArray[np.float64]

#: rows per chunk: 32k rows of 3 doubles (768 kB) and their temporaries stay in the L2/L3 cache
CHUNK_ROWS = 32_768
#: a scaled Gram matrix with a larger condition number (that of the Jacobian squared) is refused
GRAM_CONDITION = 1e14


@record
class Sums:
    """What a pass returns: ``total`` is added over chunks, ``low`` and ``high`` are running extremes."""

    total: FloatArray
    low: FloatArray
    high: FloatArray

    def __add__(self, other: Sums) -> Sums:
        return Sums(self.total + other.total, np.minimum(self.low, other.low), np.maximum(self.high, other.high))


#: ``kernel(chunk, *args, out=None) -> Sums``; writes per-row results into ``out`` when given
Kernel = Callable[..., Sums]
# Note: chunks are handled transposed, (D, rows), so that every reduction runs over contiguous memory.
#: ``reduce(kernel, args, out) -> Sums``: one pass over the data (in memory or dask blocks)
Reducer = Callable[[Kernel, tuple, "FloatArray | None"], Sums]


def reduce_chunks(points: FloatArray, kernel: Kernel, args: tuple, out: FloatArray | None = None) -> Sums:
    """One pass of ``kernel`` over ``points`` (N, D) in chunks of ``CHUNK_ROWS`` rows."""
    total: Sums | None = None
    for start in range(0, len(points), CHUNK_ROWS):
        rows = slice(start, start + CHUNK_ROWS)
        part = kernel(points[rows], *args, out=None if out is None else out[rows])
        total = part if total is None else total + part
    if total is None:
        raise ValueError("a pass over no points")
    return total


def map_chunks(points: FloatArray, function: Callable[..., FloatArray], args: tuple,
               columns: int | None = None) -> FloatArray:
    """``function(chunk, *args)`` per chunk of ``CHUNK_ROWS`` rows, into one (N,) or (N, columns) array."""
    out = np.empty(len(points) if columns is None else (len(points), columns))
    for start in range(0, len(points), CHUNK_ROWS):
        out[start:start + CHUNK_ROWS] = function(points[start:start + CHUNK_ROWS], *args)
    return out


def in_memory(points: FloatArray) -> Reducer:
    """The reducer of an in-memory array."""

    def reduce(kernel: Kernel, args: tuple, out: FloatArray | None) -> Sums:
        return reduce_chunks(points, kernel, args, out)

    return reduce


# ---------------------------------------------------------------------- moments


def moments_kernel(chunk: FloatArray, shift: FloatArray, *, out: FloatArray | None = None) -> Sums:
    """All moments of ``q = chunk - shift`` from one matrix product, and the coordinate extremes.

    The chunk is written transposed into an augmented block ``A = [1; q; |q|^2]`` of shape
    (D + 2, rows); ``A A^T`` (BLAS) holds the count, ``sum q``, ``sum |q|^2``, ``sum q q^T``
    and ``sum |q|^2 q`` (and ``sum |q|^4``, unused).  ``total`` is ``A A^T`` flattened.
    """
    del out
    dim = chunk.shape[1]
    block = np.empty((dim + 2, len(chunk)))
    block[0] = 1.0
    relative = np.subtract(chunk.T, shift[:, None], out=block[1:dim + 1])  # (D, rows), C order
    np.einsum("ij,ij->j", relative, relative, out=block[dim + 1])
    return Sums(np.matmul(block, block.T).ravel(), relative.min(axis=1) + shift, relative.max(axis=1) + shift)


@record
class Moments:
    """Moments of a point cloud from one pass (see :func:`moments`).

    Attributes
    ----------
    count : int
    centroid : ndarray, shape (D,)
    scatter : ndarray, shape (D, D)
        ``sum (p - centroid)(p - centroid)^T`` (mm^2).
    third : ndarray, shape (D,)
        ``sum |u|^2 u`` with ``u = p - centroid`` (mm^3).
    second : float
        ``sum |u|^2`` (mm^2).
    lower, upper : ndarray, shape (D,)
        Coordinate-wise extremes of the points.
    """

    count: int
    centroid: FloatArray
    scatter: FloatArray
    third: FloatArray
    second: float
    lower: FloatArray
    upper: FloatArray

    @property
    def finite(self) -> bool:
        """False when a coordinate is NaN or infinite (or the sums overflowed)."""
        return bool(np.all(np.isfinite(self.scatter)) and np.all(np.isfinite(self.third))
                    and np.all(np.isfinite(self.lower)) and np.all(np.isfinite(self.upper)))


def moments(reduce: Reducer, shift: FloatArray) -> Moments:
    """Moments of the data about their centroid, from a single pass relative to ``shift`` (a data point)."""
    dim = shift.size
    with np.errstate(over="ignore", invalid="ignore"):  # sums beyond float64 show as inf / NaN (callers check)
        sums = reduce(moments_kernel, (shift,), None)
    products = sums.total.reshape(dim + 2, dim + 2)
    count = int(products[0, 0] + 0.5)
    first = products[0, 1:dim + 1]
    second_moment = products[1:dim + 1, 1:dim + 1]
    cubic = products[1:dim + 1, dim + 1]
    squared_sum = float(products[0, dim + 1])
    mean = first / count
    with np.errstate(over="ignore", invalid="ignore"):
        scatter = second_moment - count * np.outer(mean, mean)
        scatter = (scatter + scatter.T) / 2.0
        # sum |q - m|^2 (q - m) expanded over the sums relative to the shift
        third = cubic - squared_sum * mean - 2.0 * second_moment @ mean + 2.0 * count * float(mean @ mean) * mean
        second = squared_sum - count * float(mean @ mean)
    return Moments(count=count, centroid=shift + mean, scatter=scatter, third=third, second=second,
                   lower=sums.low, upper=sums.high)


# ---------------------------------------------------------------------- normal equations


@record
class NormalEquations:
    """One Gauss-Newton pass: ``gram = J^T J``, ``rhs = -J^T r``, ``cost = r.r``, residual extremes."""

    gram: FloatArray
    rhs: FloatArray
    cost: float
    low: float
    high: float

    @classmethod
    def from_sums(cls, sums: Sums, size: int) -> NormalEquations:
        """Unpack a pass of :func:`gram_sums` over blocks ``[design (size rows); residuals]``."""
        products = sums.total.reshape(size + 1, size + 1)
        return cls(gram=products[:size, :size].copy(), rhs=products[:size, size].copy(),
                   cost=float(products[size, size]), low=float(sums.low[0]), high=float(sums.high[0]))


def gram_sums(block: FloatArray) -> Sums:
    """Per-chunk sums of a Gauss-Newton pass from one matrix product.

    ``block`` (P + 1, rows) stacks ``design = -J^T`` (P rows) over the residuals ``r``;
    ``block block^T`` (BLAS) holds ``J^T J``, ``-J^T r`` and ``r.r``.  The residual extremes
    come with it.
    """
    residuals = block[-1]
    products = np.matmul(block, block.T).ravel()
    if residuals.size == 0:
        return Sums(products, np.array([np.inf]), np.array([-np.inf]))
    return Sums(products, np.array([residuals.min()]), np.array([residuals.max()]))


def pack_normal_equations(design: FloatArray, residuals: FloatArray) -> Sums:
    """:func:`gram_sums` of ``design`` (P, rows), stored transposed, and ``residuals`` (rows,)."""
    return gram_sums(np.vstack([design, residuals[None, :]]))


def solve_scaled(gram: FloatArray, rhs: FloatArray) -> FloatArray | None:
    """Solve ``gram x = rhs`` with column scaling; None when the scaled matrix is too ill-conditioned."""
    norms = np.sqrt(np.diag(gram))
    if not np.all(norms > 0) or not np.all(np.isfinite(gram)):
        return None
    scaled = gram / np.outer(norms, norms)
    eigen = np.linalg.eigvalsh(scaled)
    if not eigen[0] > eigen[-1] / GRAM_CONDITION:
        return None
    return np.linalg.solve(scaled, rhs / norms) / norms


@record
class PassOutcome:
    """Where :func:`gauss_newton` stopped: parameters, the pass at them, convergence."""

    x: FloatArray
    equations: NormalEquations
    converged: bool
    iterations: int
    message: str


class IllConditionedSteps(Exception):
    """The normal equations are too ill-conditioned for steps from the Gram matrix (internal signal)."""


def gauss_newton(
    evaluate: Callable[[FloatArray], NormalEquations],
    x0: FloatArray,
    *,
    element: str,
    scale: float,
    local: Callable[[FloatArray], FloatArray] | None = None,
) -> PassOutcome:
    """Levenberg-Marquardt on normal equations accumulated by passes over the data.

    ``evaluate(x)`` makes one pass at ``x``.  The iteration stops as
    :func:`pcmm_geo.fit._kernels._core.solve_least_squares` does: an undamped Gauss-Newton step below
    ``TOL.step * (scale + |local(x)|)``, or a step at the rounding floor that no longer
    shrinks.  The parameters returned are those of the last pass, so the residuals and
    normal equations of that pass belong to them (no extra pass).

    Raises
    ------
    IllConditionedSteps
        The scaled Gram matrix has a condition number above ``GRAM_CONDITION``.
    ConvergenceError
        Budget or damping exhausted.
    """
    x = np.array(x0, dtype=float)
    current = evaluate(x)
    damping, previous, stalled = 0.0, np.inf, False
    message = "iteration budget exhausted"
    for iteration in range(1, TOL.max_iterations + 1):
        if not (np.isfinite(current.cost) and np.all(np.isfinite(current.gram))):
            message = "non-finite residuals or Jacobian"
            break
        step = solve_scaled(current.gram, current.rhs)
        if step is None:
            raise IllConditionedSteps(element)
        step_norm = float(np.linalg.norm(step))
        size = scale + float(np.linalg.norm(x if local is None else local(x)))
        if step_norm <= TOL.step * size or (
            step_norm <= TOL.rounding_floor * size and (step_norm >= 0.5 * previous or stalled)
        ):
            return PassOutcome(x, current, True, iteration, "converged: Gauss-Newton step below tolerance")
        previous = step_norm
        if damping > 0.0:
            damped = current.gram + damping * np.diag(np.diag(current.gram))
            step = solve_scaled(damped, current.rhs)
            if step is None:
                raise IllConditionedSteps(element)
        trial_x = x + step
        trial = evaluate(trial_x)
        if trial.cost < current.cost or (damping == 0.0 and trial.cost <= current.cost * (1 + 1e-12) + 1e-300):
            x, current = trial_x, trial
            damping = 0.0 if damping <= 1e-8 else damping / 10.0
            stalled = False
        else:
            damping = 1e-6 if damping == 0.0 else damping * 10.0
            stalled = True
            if damping > 1e12:
                message = "damping exhausted without decrease of the sum of squares"
                break
    raise ConvergenceError(element, iteration, message)


def covariance_from_gram(gram: FloatArray, cost: float, dof: int) -> tuple[FloatArray, float]:
    """``s^2 (J^T J)^-1`` with ``s^2 = cost / dof``, and the condition number of ``J``."""
    eigen, vectors = np.linalg.eigh((gram + gram.T) / 2.0)
    singular = np.sqrt(np.maximum(eigen, 0.0))
    condition = float(singular[-1] / singular[0]) if singular[0] > 0 else float("inf")
    variance = cost / dof if dof > 0 else float("nan")
    with np.errstate(divide="ignore"):
        inverse = np.where(eigen > 0, 1.0 / eigen, np.inf)
    return (vectors * inverse) @ vectors.T * variance, condition
