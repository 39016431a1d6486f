"""The seed's probe equations *as printed* (thesis eqs 2.9-2.21, Appendix E), for tests and documentation.

Never use these to compute a probe point: :func:`pcmm_geo.machine.kinematics.dpkm.dpkm_probe`
and :func:`pcmm_geo.machine.kinematics.trilateration.trilaterate` are the corrected forms.  Each
flag of :func:`seed_probe_roots_as_printed` keeps one erratum of DESIGN.md (1-4) so a
test can show what it does.

Examples
--------
>>> from pcmm_geo.machine.kinematics.dpkm import APPENDIX_E
>>> roots, disc = seed_probe_roots_as_printed(APPENDIX_E["pivots"], APPENDIX_E["lengths"],
...                                           eq_2_17_as_printed=False, eq_2_21_as_printed=False)
>>> disc < 0  # Appendix E's code: no real solution (erratum 4)
True
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.kinematics.dpkm import APPENDIX_E, _eliminate

__all__ = ["APPENDIX_E", "seed_probe_roots_as_printed"]

FloatArray = NDArray[np.float64]


def seed_probe_roots_as_printed(
    pivots: ArrayLike,
    lengths: ArrayLike,
    *,
    eq_2_17_as_printed: bool = True,
    eq_2_21_as_printed: bool = True,
    appendix_e_root: bool = True,
    absolute_heights: bool = True,
) -> tuple[NDArray[np.complex128], FloatArray]:
    """The seed's eqs 2.9-2.21 *as printed* (for tests and documentation only).

    Each flag keeps one erratum; with all four ``False`` this reproduces
    :func:`dpkm_probe`.  Appendix E's code corresponds to
    ``eq_2_17_as_printed=False, eq_2_21_as_printed=False`` (its ``-2*y1`` and ``r^2 - ...``
    are right) with ``appendix_e_root=True, absolute_heights=True``.

    Parameters
    ----------
    pivots : array_like, shape (3, 3)
    lengths : array_like, shape (3,)
    eq_2_17_as_printed : bool
        ``v = ... + 2 y_a`` (erratum 1) instead of ``- 2 y_a``.
    eq_2_21_as_printed : bool
        ``c_i = l^2 + x^2 + y^2 + z^2`` (erratum 2).
    appendix_e_root : bool
        ``y = (-1 +- sqrt(...)) / 2u`` (erratum 3) instead of ``-v``.
    absolute_heights : bool
        Feed the heights as given instead of relative to pivot a (erratum 4).

    Returns
    -------
    roots : ndarray of complex, shape (2, 3)
        Both roots (+ and - square root); complex when the discriminant is negative,
        which is what the seed then truncated to its real part.
    discriminant : float
        ``v^2 - 4uw``.

    Examples
    --------
    >>> roots, disc = seed_probe_roots_as_printed(APPENDIX_E["pivots"], APPENDIX_E["lengths"],
    ...     eq_2_17_as_printed=False, eq_2_21_as_printed=False, appendix_e_root=False)
    >>> round(disc / 1e5, 2), np.round(roots[0].real, 1).tolist()
    (-2.86, [80.0, -98.9, 126.7])
    """
    p = np.array(pivots, dtype=float)
    length = np.asarray(lengths, dtype=float)
    if p.shape != (3, 3) or length.shape != (3,):
        raise InvalidInputError("pivots/lengths", "shapes (3, 3) and (3,)", f"{p.shape} and {length.shape}")
    datum = 0.0 if absolute_heights else p[0, 2]
    p[:, 2] -= datum
    a_coef, b_coef, d_coef, f_coef, c = _eliminate(p, length, 1.0 if eq_2_21_as_printed else -1.0)
    x_a, y_a = p[0, 0], p[0, 1]
    u = 1 + b_coef**2 + d_coef**2
    v = 2 * d_coef * f_coef + 2 * x_a * b_coef - 2 * a_coef * b_coef + (2 if eq_2_17_as_printed else -2) * y_a
    w = a_coef**2 + f_coef**2 - 2 * x_a * a_coef - c[0]
    discriminant = float(v**2 - 4 * u * w)
    lead = 1.0 if appendix_e_root else v
    root_term = np.sqrt(complex(discriminant))
    roots = []
    for sign in (1.0, -1.0):
        y_root = (-lead + sign * root_term) / (2 * u)
        roots.append([a_coef - b_coef * y_root, y_root, f_coef + d_coef * y_root + datum])
    return np.array(roots, dtype=complex), discriminant
