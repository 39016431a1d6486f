"""Gaussian sphere (and circle) by passes over chunks: one moment pass, then Gauss-Newton passes.

1. **start** -- the algebraic (Kasa) sphere needs only moments about the centroid:
   ``c = S^-1 (sum |u|^2 u) / 2`` and ``r^2 = sum |u|^2 / n + |c|^2`` (``u = p - centroid``,
   ``S`` the scatter matrix), all from one pass (:func:`~pcmm_geo.fit.scale.chunked.moments`);
2. **Gauss-Newton** -- each pass accumulates the ``4 x 4`` normal equations of the
   orthogonal distances ``|p - c| - r`` chunk by chunk (Jacobian rows ``-(u / |u|, 1)``),
   with the cost and the residual extremes; the last pass, whose step is below tolerance,
   also gives the residuals, rms and form of the returned sphere (no extra pass).

Two to three Gauss-Newton passes follow the start on measured data.  The fixed point is the
one of :func:`pcmm_geo.fit._kernels._round.fit_nsphere`, the orthogonal-routine solver used for
small or ill-conditioned problems.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit.scale.chunked import (
    IllConditionedSteps,
    Moments,
    NormalEquations,
    Reducer,
    Sums,
    covariance_from_gram,
    gauss_newton,
    gram_sums,
    moments,
)

FloatArray = NDArray[np.float64]

#: smallest over largest eigenvalue of the scatter below which the algebraic start is not trusted
_FLAT = 1e-12


def sphere_kernel(chunk: FloatArray, center: FloatArray, radius: float, fixed: bool, *,
                  out: FloatArray | None = None) -> Sums:
    """Normal equations of one chunk for the sphere ``center``, ``radius`` (free radius unless ``fixed``).

    One block (P + 1, rows) holds the negated Jacobian transposed -- unit vectors ``u`` from
    the centre, and ones for a free radius -- over the residuals ``|p - c| - r``; its Gram
    matrix (:func:`~pcmm_geo.fit.scale.chunked.gram_sums`) is the whole contribution of the chunk.
    """
    dim = chunk.shape[1]
    size = dim + (not fixed)
    block = np.empty((size + 1, len(chunk)))
    relative = np.subtract(chunk.T, center[:, None], out=block[:dim])  # (D, rows), C order
    distance = np.sqrt(np.einsum("ij,ij->j", relative, relative))
    residuals = np.subtract(distance, radius, out=block[size])
    if out is not None:
        out[:] = residuals
    if distance.size and not distance.min() > 0.0:  # a point at the centre: its unit vector is taken as 0
        distance[distance == 0.0] = 1.0
    np.divide(relative, distance, out=relative)
    if not fixed:
        block[dim] = 1.0
    return gram_sums(block)


@record
class SphereSolution:
    """A chunked n-sphere fit: the element, its statistics and where the iteration stopped."""

    center: FloatArray
    radius: float
    count: int
    parameter_count: int
    cost: float
    rms: float
    form: float
    covariance: FloatArray
    condition: float
    converged: bool
    iterations: int
    message: str


def fit_nsphere_chunked(
    reduce: Reducer,
    shift: FloatArray,
    *,
    element: str,
    fixed_radius: float | None = None,
    out: FloatArray | None = None,
    data: Moments | None = None,
) -> SphereSolution:
    """Gaussian n-sphere from passes of ``reduce`` (``shift``: a point of the data, for conditioning).

    ``out`` (N,), when given, receives the residuals of the returned sphere; ``data``, the
    moments when a pass has already computed them.

    Raises
    ------
    IllConditionedSteps
        Nearly coplanar data or ill-conditioned normal equations: use the orthogonal routines.
    DegenerateGeometryError
        The least-squares radius is negative.
    ConvergenceError
        No convergence.
    """
    data = moments(reduce, shift) if data is None else data
    if not data.finite:  # sums overflowed (coordinates far beyond any CMM's range)
        raise IllConditionedSteps(element)
    dim = shift.size
    count = data.count
    eigen = np.linalg.eigvalsh(data.scatter)
    if not eigen[0] > _FLAT * eigen[-1]:
        raise IllConditionedSteps(element)
    start_local = np.linalg.solve(data.scatter, data.third) / 2.0
    size = float(np.sqrt(data.second / count))
    fixed = fixed_radius is not None
    if fixed:
        x0 = data.centroid + start_local
    else:
        x0 = np.append(data.centroid + start_local, np.sqrt(data.second / count + start_local @ start_local))
    size_of = dim + (not fixed)
    last: list[FloatArray] = []

    def evaluate(params: FloatArray) -> NormalEquations:
        radius = float(fixed_radius) if fixed_radius is not None else float(params[dim])
        last[:] = [params]
        return NormalEquations.from_sums(reduce(sphere_kernel, (params[:dim], radius, fixed), out), size_of)

    def local(params: FloatArray) -> FloatArray:
        return params[:dim] - data.centroid

    outcome = gauss_newton(evaluate, x0, element=element, scale=size, local=local)
    if out is not None and last[0] is not outcome.x:  # a rejected trial came last: residuals of the result
        evaluate(outcome.x)
    center = outcome.x[:dim]
    radius = float(fixed_radius) if fixed_radius is not None else float(outcome.x[dim])
    if radius < 0:
        raise DegenerateGeometryError(element, "the least-squares solution has a negative radius")
    equations = outcome.equations
    covariance, condition = covariance_from_gram(equations.gram, equations.cost, count - size_of)
    if fixed:
        full = np.zeros((dim + 1, dim + 1))
        full[:dim, :dim] = covariance
        covariance = full
    return SphereSolution(center=center, radius=radius, count=count, parameter_count=size_of, cost=equations.cost,
                          rms=float(np.sqrt(equations.cost / count)), form=equations.high - equations.low,
                          covariance=covariance, condition=condition, converged=outcome.converged,
                          iterations=outcome.iterations, message=outcome.message)
