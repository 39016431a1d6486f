"""Fits and distances at scale: chunked passes over large arrays, and dask arrays out of core.

* :mod:`~pcmm_geo.fit.scale.chunked` -- the data are read in cache-sized chunks of rows
  (``CHUNK_ROWS``): moments, and the normal equations of a Gauss-Newton step, are
  accumulated chunk by chunk without full-size temporaries;
* :mod:`~pcmm_geo.fit.scale.dask` -- the same per-chunk kernels run on every block of a
  ``dask.array.Array`` and their small sums are added up (a map-reduce per pass), on
  whatever scheduler is active; the array is never materialised.

``fit_line``, ``fit_plane``, ``fit_sphere`` and ``fit_cylinder`` route a dask array here;
dask is imported only when one is passed (:func:`is_dask_array` looks at the type only).
"""

from __future__ import annotations

from typing import Any

__all__ = ["is_dask_array"]


def is_dask_array(value: Any) -> bool:
    """True for a ``dask.array.Array`` (recognised by its type, without importing dask).

    Examples
    --------
    >>> import numpy as np
    >>> is_dask_array(np.zeros((3, 3)))
    False
    """
    kind = type(value)
    return kind.__name__ == "Array" and kind.__module__.startswith("dask.array")
