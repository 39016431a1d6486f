"""Form evaluation of many small round features at once: ``(K, N, 2)`` or ``(K, N, 3)`` roundness profiles.

Each profile is solved by the same exact global method as :func:`pcmm_geo.fit.fit_circle`
(:mod:`pcmm_geo.fit.zone._exact`: a few milliseconds per profile), so a batch answer is
exactly the single fit's, with the same certificate; a profile that cannot be fitted does not
stop the others.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import InvalidInputError, PcmmGeoError

__all__ = ["RoundnessBatch", "roundness_profiles"]

FloatArray = NDArray[np.float64]


@record
class RoundnessBatch:
    """Minimax circles of ``K`` profiles.

    Attributes
    ----------
    criterion : str
        ``"chebyshev"``, ``"mcc"`` or ``"mic"``.
    center : ndarray, shape (K, D)
        Centres (mm), D = 2 or 3.
    radius, r_in, r_out, form : ndarray, shape (K,)
        Reported radius (mid-zone / circumscribed / inscribed), zone radii, zone width (mm);
        NaN for a profile that raised.
    converged : ndarray of bool, shape (K,)
        Certified optimum.
    scope : tuple of K str
        ``"global"`` (proven over the certificate's domain) or ``"local"`` per profile ("" for a
        profile that raised).
    bound : ndarray, shape (K,)
        Proven bound of each optimum (mm): lower bound of the zone width / enclosing radius,
        upper bound of the inscribed radius; NaN for a profile that raised.
    contacts : tuple of K int arrays
        Support point indices of each profile.
    messages : tuple of K str
        Solver message, or the error of a profile that could not be fitted.
    """

    criterion: Criterion
    center: FloatArray
    radius: FloatArray
    r_in: FloatArray
    r_out: FloatArray
    form: FloatArray
    converged: NDArray[np.bool_]
    contacts: tuple[NDArray[np.intp], ...]
    messages: tuple[str, ...]
    scope: tuple[str, ...]
    bound: FloatArray


def roundness_profiles(profiles: ArrayLike, *, criterion: Criterion = "chebyshev") -> RoundnessBatch:
    """Minimum-zone (or MCC / MIC) circles of a stack of profiles.

    Parameters
    ----------
    profiles : array_like, shape (K, N, 2) or (K, N, 3)
        K profiles of N points each (mm).
    criterion : {"chebyshev", "mcc", "mic"}

    Returns
    -------
    RoundnessBatch
        A profile that cannot be fitted (NaN, collinear, unbounded MIC) gets NaN values,
        ``converged=False`` and the error text in ``messages``; the others are unaffected.

    Raises
    ------
    InvalidInputError
        Wrong shape or criterion.

    Examples
    --------
    >>> angles = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    >>> lobes = np.array([0.001, 0.002, 0.003])[:, None] * np.cos(3 * angles)
    >>> radii = 4.0 + lobes
    >>> stack = np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=-1)
    >>> batch = roundness_profiles(stack)
    >>> np.round(batch.form, 9).tolist(), batch.converged.tolist()
    ([0.002, 0.004, 0.006], [True, True, True])
    """
    from pcmm_geo.fit.circle import fit_circle

    if criterion not in ("chebyshev", "mcc", "mic"):
        raise InvalidInputError("criterion", "one of 'chebyshev', 'mcc', 'mic'", repr(criterion))
    try:
        stack = np.asarray(profiles, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError("profiles", "an array of numbers", str(exc)) from None
    if stack.ndim != 3 or stack.shape[2] not in (2, 3):
        raise InvalidInputError("profiles", "shape (K, N, 2) or (K, N, 3)", f"shape {stack.shape}")
    count, _, dim = stack.shape
    center = np.full((count, dim), np.nan)
    radius, r_in, r_out, form, bound = (np.full(count, np.nan) for _ in range(5))
    converged = np.zeros(count, dtype=bool)
    contacts: list[NDArray[np.intp]] = []
    messages: list[str] = []
    scope: list[str] = []
    for k in range(count):
        try:
            fit = fit_circle(stack[k], criterion=criterion)
        except PcmmGeoError as exc:
            contacts.append(np.zeros(0, dtype=np.intp))
            messages.append(f"{type(exc).__name__}: {exc}")
            scope.append("")
            continue
        center[k] = fit.center
        radius[k], r_in[k], r_out[k], form[k] = fit.radius, fit.r_in, fit.r_out, fit.form
        converged[k] = fit.converged
        contacts.append(fit.contacts)
        messages.append(fit.message)
        certificate = fit.certificate
        scope.append("" if certificate is None else certificate.scope)
        bound[k] = np.nan if certificate is None else certificate.bound_mm
    return RoundnessBatch(
        criterion, center, radius, r_in, r_out, form, converged, tuple(contacts), tuple(messages), tuple(scope), bound
    )
