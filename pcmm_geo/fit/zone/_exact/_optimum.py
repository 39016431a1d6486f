"""What an exact solver returns (internal; parameters in the solver's local coordinates)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record

FloatArray = NDArray[np.float64]


@record
class ExactOptimum:
    """A global optimum and its proof.

    Attributes
    ----------
    x : ndarray
        Centre (circle, sphere; local coordinates) or unit normal (strip, slab).
    lower, upper : float
        The zone's levels (distances from the centre / offsets along the normal) over all points.
    bound : float
        Proven bound of the optimum over the domain: a lower bound of the zone width or of the
        enclosing radius, an upper bound of the empty radius (mm).
    contacts : dict
        Support points ``{index: +1 upper level / -1 lower level}``.
    iterations : int
        Rounds of the search.
    method : str
        The exact method that found it.
    """

    x: FloatArray
    lower: float
    upper: float
    bound: float
    contacts: dict[int, float]
    iterations: int
    method: str
