"""Linear thermal expansion of machine members (thesis eq 4.1) and the seed's faulty variant.

The thesis models every member of the micro-CMM (frame sides, upright columns,
tetrahedron arms) as a bar that lengthens in proportion to its length and its
temperature change, ``Δl = α · l0 · ΔT`` (eq 4.1).  The MATLAB code of
Appendix E instead computes ``α · 10 · ΔT`` and ignores the length (erratum 5);
:func:`seed_delta_l` reproduces that so the two can be compared.

Units: lengths in mm, temperatures in °C (differences in K), ``alpha`` in 1/K.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError

__all__ = [
    "ALPHA_ALUMINIUM",
    "ALPHA_GAUGE_BLOCK_STEEL",
    "ALPHA_STEEL",
    "REFERENCE_TEMPERATURE",
    "delta_l",
    "expanded_length",
    "seed_delta_l",
]

FloatArray = NDArray[np.float64]

#: Standard reference temperature of geometrical product specification (ISO 1), °C.
REFERENCE_TEMPERATURE = 20.0
#: Expansion coefficient of aluminium used by the seed code (Appendix E, ``alpha = 23.1e-6``), 1/K.
ALPHA_ALUMINIUM = 23.1e-6
#: A typical structural/tool steel, 1/K.
ALPHA_STEEL = 11.5e-6
#: Steel gauge blocks (ISO 3650 gives (11.5 ± 1) · 10⁻⁶ /K), 1/K.
ALPHA_GAUGE_BLOCK_STEEL = 11.5e-6


def _finite(value: ArrayLike, name: str) -> FloatArray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(name, "a number or an array of numbers", f"{type(value).__name__}") from None
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, "finite values", f"{arr.tolist()}")
    return arr


def _result(arr: FloatArray) -> FloatArray | float:
    return float(arr) if arr.ndim == 0 else arr


def delta_l(length: ArrayLike, delta_t: ArrayLike, alpha: ArrayLike = ALPHA_ALUMINIUM) -> FloatArray | float:
    """Change of length of a bar, ``Δl = α · l0 · ΔT`` (thesis eq 4.1).

    Parameters
    ----------
    length : float or array_like
        Original length ``l0`` at the reference state (mm), any shape.
    delta_t : float or array_like
        Temperature change ``ΔT`` (K), broadcast against ``length``.
    alpha : float or array_like
        Linear expansion coefficient (1/K); default aluminium, 23.1e-6 /K.

    Returns
    -------
    float or ndarray
        ``Δl`` in mm (a float for scalar input).

    Raises
    ------
    InvalidInputError
        Non-numeric or non-finite input.

    Examples
    --------
    >>> round(delta_l(650.0, 1.0), 9)   # a 650 mm aluminium frame side warmed by 1 K
    0.015015
    """
    l0 = _finite(length, "length")
    dt = _finite(delta_t, "delta_t")
    a = _finite(alpha, "alpha")
    return _result(np.asarray(a * l0 * dt, dtype=float))


def expanded_length(
    length: ArrayLike,
    temperature: ArrayLike,
    alpha: ArrayLike = ALPHA_ALUMINIUM,
    reference_temperature: float = REFERENCE_TEMPERATURE,
) -> FloatArray | float:
    """Length at ``temperature`` of a member that measures ``length`` at the reference temperature.

    ``l' = l0 + Δl = l0 (1 + α (T − T_ref))`` (thesis eqs 4.1 and 4.3).

    Parameters
    ----------
    length : float or array_like
        Length at ``reference_temperature`` (mm).
    temperature : float or array_like
        Member temperature (°C).
    alpha : float or array_like
        Expansion coefficient (1/K).
    reference_temperature : float
        Temperature at which ``length`` holds (°C), default 20 °C (ISO 1).

    Returns
    -------
    float or ndarray
        Expanded length (mm).

    Raises
    ------
    InvalidInputError
        Non-numeric or non-finite input.

    Examples
    --------
    >>> round(expanded_length(100.0, 25.0, alpha=11.5e-6), 9)
    100.00575
    """
    l0 = _finite(length, "length")
    temp = _finite(temperature, "temperature")
    return _result(np.asarray(l0 + np.asarray(delta_l(l0, temp - reference_temperature, alpha)), dtype=float))


def seed_delta_l(
    length: ArrayLike,
    start_temperature: ArrayLike,
    end_temperature: ArrayLike,
    alpha: float = ALPHA_ALUMINIUM,
) -> FloatArray | float:
    """The seed code's ``delta_l`` (Appendix E, lines 221-228), kept only to show erratum 5.

    Appendix E computes ``α · 10 · (Tf − T0)``: the length argument is accepted and
    *ignored*, so every member expands as if it were 10 mm long.  The correct
    expansion is :func:`delta_l` (eq 4.1).  For a 650 mm side and 1 K the seed gives
    0.000231 mm instead of 0.015015 mm (65 times too small).

    Parameters
    ----------
    length : float or array_like
        Member length (mm) -- ignored, as in the seed; only its shape is used.
    start_temperature, end_temperature : float or array_like
        ``T0`` and ``Tf`` (°C or K, only the difference matters).
    alpha : float
        Expansion coefficient (1/K), the seed's 23.1e-6 by default.

    Returns
    -------
    float or ndarray
        The seed's (wrong) ``Δl`` in mm.

    Raises
    ------
    InvalidInputError
        Non-numeric or non-finite input.

    Examples
    --------
    >>> round(seed_delta_l(650.0, 20.0, 21.0), 9)
    0.000231
    """
    l0 = _finite(length, "length")
    dt = _finite(end_temperature, "end_temperature") - _finite(start_temperature, "start_temperature")
    return _result(np.asarray(alpha * 10.0 * dt + 0.0 * l0, dtype=float))
