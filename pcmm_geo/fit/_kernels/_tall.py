"""Least-squares kernels for tall matrices (many more rows than columns).

For a million points the orthogonal-decomposition routines (``lstsq``, ``svd``) of the
whole ``(N, P)`` Jacobian dominate a fit's time, while the ``P x P`` Gram matrix costs one
pass.  When the column-scaled Gram matrix is well conditioned (condition of the matrix
itself below ``_GRAM_CONDITION``, so that squaring it loses at most about six of sixteen
digits) the normal equations are solved instead; otherwise the orthogonal routines are
used.  Gauss-Newton converges to the same point either way: the fixed point ``J^T r = 0``
does not depend on how accurately each step is solved.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

TALL_ROWS = 20_000  # below this many rows the orthogonal routines are cheap enough
_GRAM_CONDITION = 1e5


def _scaled_gram(matrix: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """Gram matrix, column norms and column-scaled Gram matrix; None when not tall or too ill-conditioned."""
    if matrix.shape[0] < TALL_ROWS:
        return None
    gram = matrix.T @ matrix
    norms = np.sqrt(np.diag(gram))
    if not np.all(norms > 0):
        return None
    scaled = gram / np.outer(norms, norms)
    eigen = np.linalg.eigvalsh(scaled)
    if not eigen[0] > eigen[-1] / _GRAM_CONDITION**2:
        return None
    return gram, norms, scaled


def tall_lstsq(matrix: FloatArray, rhs: FloatArray) -> FloatArray:
    """Least-squares solution of ``matrix @ x ~ rhs`` for ``matrix`` of shape (M, P)."""
    gram = _scaled_gram(matrix)
    if gram is None:
        return np.linalg.lstsq(matrix, rhs, rcond=None)[0]
    _, norms, scaled = gram
    return np.linalg.solve(scaled, (matrix.T @ rhs) / norms) / norms


def tall_svd(matrix: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Singular values (descending) and right singular vectors (rows) of ``matrix`` (M, P)."""
    gram = _scaled_gram(matrix)
    if gram is None:
        _, singular, vt = np.linalg.svd(matrix, full_matrices=False)
        return singular, vt
    eigen, vectors = np.linalg.eigh(gram[0])
    order = np.argsort(eigen)[::-1]
    return np.sqrt(np.maximum(eigen[order], 0.0)), vectors[:, order].T
