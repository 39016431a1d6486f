"""Column-line calibration from pivot probings at several heights (thesis eqs 2.19-2.20).

Each pivot (spherical joint on its lead-screw bracket) is probed, or its center measured,
at K >= 2 bracket heights.  Per column the seed's "vertical error" model

    ``x_i = g_i + h_i z_i``   (eq 2.19)        ``y_i = m_i + n_i z_i``   (eq 2.20)

is fitted by least squares of the centers' x and y on their z coordinate (intercepts
``g, m`` in mm, slopes ``h, n`` unitless).  The same line becomes the rigid-body
model's :class:`~pcmm_geo.machine.kinematics.model.ColumnLine`: direction ``(h, n, 1)/|(h, n, 1)|``,
and ``encoder_scale`` / point from regressing the distance along the line on the height
reading, so that ``ColumnLine.pivot(reading)`` returns the measured centers.

Examples
--------
>>> import numpy as np
>>> heights = np.array([0.0, 50.0, 100.0])
>>> centers = {arm: np.c_[10 + 0.01 * heights, 5 - 0.02 * heights, 400 + heights] for arm in "abc"}
>>> columns = calibrate_columns(centers, {arm: heights for arm in "abc"})
>>> round(columns.intercepts["a"][0], 9), round(columns.slopes["a"][1], 9)
(6.0, -0.02)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._deprecation import renamed_fields
from pcmm_geo._records import record
from pcmm_geo.errors import CalibrationError, InvalidInputError
from pcmm_geo.machine.calibration.geometry import fit_probed_sphere

if TYPE_CHECKING:
    from pcmm_geo.machine.kinematics.model import ColumnLine

__all__ = ["ColumnCalibration", "calibrate_columns"]

FloatArray = NDArray[np.float64]
ARMS = ("a", "b", "c")


@renamed_fields(centres="centers")
@record
class ColumnCalibration:
    """Result of :func:`calibrate_columns` (machine frame, mm).

    Attributes
    ----------
    intercepts : dict
        ``{arm: (g, m)}`` of eqs 2.19-2.20 (mm).
    slopes : dict
        ``{arm: (h, n)}`` (unitless).
    encoder_scale, encoder_offset : dict
        ``{arm: value}``: distance along the column = scale * reading + offset (mm).
    straightness : dict
        ``{arm: value}``: diameter of the cylinder about the line holding all centers (mm).
    residuals : dict
        ``{arm: (K,)}`` orthogonal distance of each center from its line (mm).
    centers : dict
        ``{arm: (K, 3)}`` pivot centers used.
    heights : dict
        ``{arm: (K,)}`` height readings used.
    """

    intercepts: Mapping[str, tuple[float, float]]
    slopes: Mapping[str, tuple[float, float]]
    encoder_scale: Mapping[str, float]
    encoder_offset: Mapping[str, float]
    straightness: Mapping[str, float]
    residuals: Mapping[str, FloatArray]
    centers: Mapping[str, FloatArray]
    heights: Mapping[str, FloatArray]

    def base_point(self, arm: str) -> FloatArray:
        """Where the column line crosses z = 0: ``(g, m, 0)`` (mm)."""
        g, m = self.intercepts[arm]
        return np.array([g, m, 0.0])

    def direction(self, arm: str) -> FloatArray:
        """Unit direction ``(h, n, 1) / |(h, n, 1)|``."""
        h, n = self.slopes[arm]
        vector = np.array([h, n, 1.0])
        return vector / np.linalg.norm(vector)

    @property
    def columns(self) -> dict[str, ColumnLine]:
        """Rigid-body :class:`~pcmm_geo.machine.kinematics.model.ColumnLine` per arm (pivot at reading 0: ``point``)."""
        from pcmm_geo.machine.kinematics.model import ColumnLine

        out = {}
        for arm in ARMS:
            direction = self.direction(arm)
            point = self.base_point(arm) + self.encoder_offset[arm] * direction
            out[arm] = ColumnLine(point, direction, float(self.encoder_scale[arm]))
        return out


def _centres(arm: str, value: Any) -> FloatArray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):  # ragged: point sets of different sizes
        arr = None
    if arr is not None and arr.ndim == 2 and arr.shape[1] == 3:
        return arr
    # sequence of probed point sets, one per height
    return np.array([fit_probed_sphere(points, what=f"pivot {arm} height {k}").center for k, points in
                     enumerate(value)])


def calibrate_columns(pivots: Mapping[str, Any], heights: Any) -> ColumnCalibration:
    r"""Fit the three column lines (eqs 2.19-2.20) and their encoder scales.

    Parameters
    ----------
    pivots : mapping
        ``{arm: (K, 3) centers}`` or ``{arm: [(N, 3) probed points per height]}`` (mm,
        machine frame).
    heights : mapping or array_like
        ``{arm: (K,)}`` height readings, or an array (K, 3) in arm order a, b, c.

    Returns
    -------
    ColumnCalibration

    Raises
    ------
    InvalidInputError
        Missing arms, shapes that do not match, non-finite values.
    CalibrationError
        Fewer than two heights, or heights / z coordinates that do not vary.

    See Also
    --------
    pcmm_geo.machine.calibration.tetrahedron.calibrate_tetrahedron : the tetrahedron parameters (thesis ch. 7)

    Notes
    -----
    Each pivot travels on a straight column line, thesis eqs 2.19-2.20 [1]_:

    .. math::

        x_i = g_i + h_i z_i , \qquad y_i = m_i + n_i z_i ,

    fitted by least squares of the pivot centres' :math:`x` and :math:`y` on their :math:`z`;
    the encoder scale and offset by regressing the distance along that line on the height
    reading.

    References
    ----------
    .. [1] *A critical investigation into the accuracy of a parallel mechanism coordinate measuring machine*,
           MEng (Mechatronic) thesis, Faculty of Engineering, Stellenbosch University ("the thesis"; the copy
           the project works from names neither author nor year). Section 2.6.4, eqs 2.19-2.20.

    Examples
    --------
    See the module docstring.
    """
    if not isinstance(pivots, Mapping) or set(pivots) != set(ARMS):
        raise InvalidInputError("pivots", "a mapping with keys 'a', 'b', 'c'", repr(type(pivots).__name__))
    if isinstance(heights, Mapping):
        readings = {arm: np.asarray(heights[arm], dtype=float).reshape(-1) for arm in ARMS}
    else:
        table = np.asarray(heights, dtype=float)
        if table.ndim != 2 or table.shape[1] != 3:
            raise InvalidInputError("heights", "shape (K, 3) or a mapping per arm", f"shape {table.shape}")
        readings = {arm: table[:, k] for k, arm in enumerate(ARMS)}
    fields: dict[str, dict[str, Any]] = {key: {} for key in
                                         ("intercepts", "slopes", "scale", "offset", "straight", "res", "centers")}
    for arm in ARMS:
        centers = _centres(arm, pivots[arm])
        reading = readings[arm]
        if centers.shape[0] != reading.shape[0]:
            raise InvalidInputError(f"heights[{arm!r}]", f"{centers.shape[0]} readings (one per pivot center)",
                                    f"{reading.shape[0]}")
        if not (np.all(np.isfinite(centers)) and np.all(np.isfinite(reading))):
            raise InvalidInputError(f"pivots[{arm!r}]", "finite centers and heights", "NaN or inf")
        if centers.shape[0] < 2 or np.ptp(centers[:, 2]) == 0 or np.ptp(reading) == 0:
            raise CalibrationError(
                f"column {arm}: expected >= 2 pivot centers at different heights, got z = {centers[:, 2].tolist()} "
                f"and readings {reading.tolist()}"
            )
        design = np.c_[np.ones(centers.shape[0]), centers[:, 2]]
        (g, h), *_ = np.linalg.lstsq(design, centers[:, 0], rcond=None)
        (m, n), *_ = np.linalg.lstsq(design, centers[:, 1], rcond=None)
        direction = np.array([h, n, 1.0]) / np.linalg.norm([h, n, 1.0])
        offsets = centers - np.array([g, m, 0.0])
        along = offsets @ direction
        distances = np.linalg.norm(offsets - along[:, None] * direction, axis=1)
        scale, offset = np.polyfit(reading, along, 1)
        fields["intercepts"][arm] = (float(g), float(m))
        fields["slopes"][arm] = (float(h), float(n))
        fields["scale"][arm] = float(scale)
        fields["offset"][arm] = float(offset)
        fields["straight"][arm] = 0.0 if centers.shape[0] == 2 else float(2 * distances.max())
        fields["res"][arm] = distances
        fields["centers"][arm] = centers
    return ColumnCalibration(
        intercepts=fields["intercepts"],
        slopes=fields["slopes"],
        encoder_scale=fields["scale"],
        encoder_offset=fields["offset"],
        straightness=fields["straight"],
        residuals=fields["res"],
        centers=fields["centers"],
        heights=readings,
    )
