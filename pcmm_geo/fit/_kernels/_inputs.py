"""Input validation shared by every fit (one implementation), and the compensated centroid.

Every public fit converts its arguments here, so that the same bad input gets the same
typed error everywhere: complex numbers, strings, ragged lists, NaN/inf, coordinates
whose squares overflow float64, and non-scalar or non-positive lengths.
"""

from __future__ import annotations

import numbers

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError

FloatArray = NDArray[np.float64]

#: Largest coordinate magnitude accepted (mm): squares and sums of squares of such numbers
#: (and of differences of them) stay far from float64 overflow (about 1.8e308).
MAX_COORDINATE = 1e150


def _describe(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def real_array(value: ArrayLike, name: str) -> FloatArray:
    """Convert ``value`` to a float64 array, refusing what is not a real number.

    Parameters
    ----------
    value : array_like
        Numbers (bool, int, float, or objects convertible with ``float``).
    name : str
        Argument name used in the error.

    Raises
    ------
    InvalidInputError
        Complex numbers, strings/bytes, ragged nesting or objects that are not numbers.
        (NaN/inf are left to the caller, which names the offending row.)

    Examples
    --------
    >>> real_array([1, 2.5], "weights").tolist()
    [1.0, 2.5]
    >>> real_array(["1", "2"], "weights")
    Traceback (most recent call last):
    ...
    pcmm_geo.errors.InvalidInputError: weights: expected real numbers, got strings ['1', '2']
    """
    if isinstance(value, (str, bytes)):
        raise InvalidInputError(name, "real numbers", f"a string {_describe(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:  # ragged nesting on recent numpy
        raise InvalidInputError(name, "an array of real numbers", f"{type(value).__name__} ({exc})") from None
    kind = raw.dtype.kind
    if kind == "c":
        raise InvalidInputError(name, "real numbers", f"complex values (dtype {raw.dtype})")
    if kind in "USa":
        raise InvalidInputError(name, "real numbers", f"strings {_describe(raw.tolist())}")
    if kind in "biuf":
        return np.asarray(raw, dtype=float)
    # object arrays: accept real scalars only (Fraction, Decimal, mpmath numbers, ...)
    flat = raw.ravel()
    for item in flat:
        if isinstance(item, (str, bytes)):
            raise InvalidInputError(name, "real numbers", f"a string {_describe(item)}")
        if isinstance(item, complex | np.complexfloating) or (
            isinstance(item, numbers.Complex) and not isinstance(item, numbers.Real)
        ):
            raise InvalidInputError(name, "real numbers", f"a complex value {_describe(item)}")
    try:
        return np.asarray(raw, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(name, "an array of real numbers", f"{type(value).__name__} ({exc})") from None


def check_magnitude(arr: FloatArray, name: str) -> None:
    """Refuse finite coordinates so large that the fit's squares would overflow float64."""
    if arr.size == 0 or (float(arr.max()) <= MAX_COORDINATE and float(arr.min()) >= -MAX_COORDINATE):
        return
    biggest = float(np.max(np.abs(arr)))
    if biggest > MAX_COORDINATE:
        index = np.unravel_index(int(np.argmax(np.abs(arr))), arr.shape)
        where = f" at index {tuple(int(i) for i in index)}" if arr.ndim else ""
        raise InvalidInputError(
            name,
            f"coordinates of magnitude at most {MAX_COORDINATE:g} mm (their squares must not overflow float64)",
            f"{biggest:g}{where}",
        )


def positive_length(value: object, name: str) -> float:
    """A single positive finite length (mm) as a float, e.g. a fixed radius.

    Raises
    ------
    InvalidInputError
        A string, a sequence or array (even of one element), a bool, a complex number,
        NaN/inf, zero or a negative value.

    Examples
    --------
    >>> positive_length(10, "radius")
    10.0
    >>> positive_length([10], "radius")
    Traceback (most recent call last):
    ...
    pcmm_geo.errors.InvalidInputError: radius: expected one positive finite number (mm), got list [10]
    """
    expected = "one positive finite number (mm)"
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
            value = value.item()
        else:
            raise InvalidInputError(name, expected, f"{type(value).__name__} {_describe(value)}")
    number = float(value)
    if not (np.isfinite(number) and number > 0):
        raise InvalidInputError(name, expected, _describe(value))
    return number


def weighted_centroid(points: FloatArray, weights: FloatArray | None = None, *, axis: int = -2) -> FloatArray:
    """Compensated (two-pass) centroid of ``points`` along ``axis``, weighted when ``weights`` is given.

    The first pass is the plain mean; the second adds the mean of the deviations from it,
    which are exact differences of nearby numbers, so the rounding of the first pass
    (about ``N eps |offset|`` for a column sum) is removed: for 1e6 points 1e5 mm from the
    origin the error drops from about 2e-9 mm to below 1e-12 mm.

    Parameters
    ----------
    points : ndarray, shape (..., N, D)
        Points (mm).
    weights : ndarray, shape (..., N), optional
        Non-negative weights, not all zero along ``axis``.
    axis : int
        Axis of the points (default: the second to last).

    Returns
    -------
    ndarray, shape (..., D)

    Examples
    --------
    >>> pts = np.array([[1e5 + 0.25, 0.0], [1e5 + 0.5, 1.0], [1e5 + 0.75, 2.0]])
    >>> (weighted_centroid(pts) - [1e5, 0.0]).tolist()
    [0.5, 1.0]
    """
    if weights is None:
        first = np.mean(points, axis=axis, keepdims=True)
        return np.squeeze(first + np.mean(points - first, axis=axis, keepdims=True), axis=axis)
    w = np.expand_dims(weights, -1)
    total = np.sum(w, axis=axis, keepdims=True)
    first = np.sum(w * points, axis=axis, keepdims=True) / total
    return np.squeeze(first + np.sum(w * (points - first), axis=axis, keepdims=True) / total, axis=axis)
