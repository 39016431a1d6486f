"""Data and parameters of the numerical calibration (thesis ch. 6): the height-gauge experiment.

See :mod:`pcmm_geo.machine.calibration.numerical.numcal` for the model and the solvers.  CSV format of
the experiment: header ``moved,laser_a,laser_b,laser_c,height`` (mm); ``moved`` is the arm
whose pivot bracket was moved, ``height`` the height-gauge reading of that pivot relative to
the level start (the other two pivots stand at the start).  A second header,
``moved,laser_a,laser_b,laser_c,height_a,height_b,height_c``, gives all three pivot heights
(designs that move several pivots).

Dead distances ``d`` exclude the lasers' 60 mm start of range (Table 7.1's convention,
``L = laser + 60 + d``).  Appendix B's code adds its dead distance to the raw laser reading
(``li + X(1)``), so its GA bounds of 300-400 mm include the 60 mm; :data:`SEED_BOUNDS` are
those bounds in this library's convention, 240-340 mm (Table 6.2's "Expected" 349.40 and
354.02 mm are Table 3.1's 289.40 and 294.02 mm plus 60).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.io.text import excerpt, parse_decimal

__all__ = [
    "APPENDIX_B_BOUNDS_AS_PRINTED",
    "LEVEL_START_HEIGHT",
    "MOVED_PAIR",
    "PARAMETER_NAMES",
    "SEED_BOUNDS",
    "NumcalData",
    "NumcalParameters",
    "numcal_machine",
    "read_numcal_csv",
    "synthesise_design_data",
    "synthesise_numcal_data",
    "write_numcal_csv",
]

FloatArray = NDArray[np.float64]
ARMS = ("a", "b", "c")
PARAMETER_NAMES = ("d_a", "d_b", "d_c", "beta_ab", "beta_bc", "beta_ca", "b_ab", "b_bc", "b_ca")
#: moved arm -> (stationary arm i, moved arm in, pair name)
MOVED_PAIR = {"a": ("c", "a", "ca"), "b": ("a", "b", "ab"), "c": ("b", "c", "bc")}
_PAIR_INDEX = {"ab": 0, "bc": 1, "ca": 2}
#: arm indices (i, in) of the pairs ab, bc, ca
PAIR_ARMS = ((0, 1), (1, 2), (2, 0))
#: Appendix B's GA bounds as printed (d_i, d_in, beta_in in degrees, b_in): d includes the 60 mm
APPENDIX_B_BOUNDS_AS_PRINTED = ((300.0, 300.0, 60.0, 400.0), (400.0, 400.0, 80.0, 500.0))
START_OF_RANGE = 60.0
#: Appendix B's GA bounds in this library's convention (d without the 60 mm start of range,
#: beta in radians): d 240-340 mm, beta 60-80 degrees, b 400-500 mm
SEED_BOUNDS = (
    np.array([300.0 - START_OF_RANGE] * 3 + [np.radians(60.0)] * 3 + [400.0] * 3),
    np.array([400.0 - START_OF_RANGE] * 3 + [np.radians(80.0)] * 3 + [500.0] * 3),
)
#: column height (mm) of the level start of the synthetic experiments (the columns are vertical,
#: so the value changes no reading; it keeps the pivots inside the 450 mm travel)
LEVEL_START_HEIGHT = 100.0


@dataclass(frozen=True)
class NumcalParameters:
    """The nine parameters: ``d`` {'a','b','c'} mm, ``beta`` {'ab','bc','ca'} radians, ``b`` {'ab','bc','ca'} mm."""

    d: Mapping[str, float]
    beta: Mapping[str, float]
    b: Mapping[str, float]

    @property
    def beta_deg(self) -> dict[str, float]:
        """Arm angles in degrees."""
        return {pair: float(np.degrees(value)) for pair, value in self.beta.items()}

    def vector(self) -> FloatArray:
        """Parameters in :data:`PARAMETER_NAMES` order, shape (9,)."""
        return np.array([*(self.d[a] for a in ARMS), *(self.beta[p] for p in _PAIR_INDEX), *(self.b[p] for p in
                                                                                             _PAIR_INDEX)], float)

    @classmethod
    def from_vector(cls, vector: ArrayLike) -> NumcalParameters:
        """Inverse of :meth:`vector`."""
        v = np.asarray(vector, dtype=float).reshape(9)
        pairs = tuple(_PAIR_INDEX)
        return cls(
            d={arm: float(v[k]) for k, arm in enumerate(ARMS)},
            beta={pair: float(v[3 + k]) for k, pair in enumerate(pairs)},
            b={pair: float(v[6 + k]) for k, pair in enumerate(pairs)},
        )

    @classmethod
    def from_seed_table(cls) -> NumcalParameters:
        """Table 7.1's values (d, beta, b per arm; arm i's beta and b belong to pair i-in)."""
        return cls.from_vector(
            [314.48, 312.74, 309.42, np.radians(68.25), np.radians(69.03), np.radians(68.70), 454.17, 462.47, 461.67]
        )


@record
class NumcalData:
    """Height-gauge experiment (thesis 6.2): per sample the moved arm, three lasers and the heights.

    Attributes
    ----------
    moved : tuple of str
        Arm moved for each sample (``'a'``, ``'b'`` or ``'c'``), length M.  The seed's model
        uses the pair of the moved arm and the previous one (:data:`MOVED_PAIR`).
    lasers : ndarray, shape (M, 3)
        Laser readings a, b, c (mm, without the 60 mm start of range).
    heights : ndarray, shape (M,)
        Height-gauge reading of the moved pivot relative to the level start (mm).
    pivot_heights : ndarray, shape (M, 3), optional
        Heights of all three pivots relative to the level start (mm).  Default: ``heights`` at
        the moved arm, 0 at the two others (the seed's experiment).  When given, ``heights``
        must equal its moved-arm column.
    """

    moved: tuple[str, ...]
    lasers: FloatArray
    heights: FloatArray
    pivot_heights: FloatArray | None = None

    def __post_init__(self) -> None:
        lasers = np.asarray(self.lasers, dtype=float)
        heights = np.asarray(self.heights, dtype=float)
        count = len(self.moved)
        if lasers.shape != (count, 3) or heights.shape != (count,):
            raise InvalidInputError(
                "numcal data", f"lasers ({count}, 3) and heights ({count},)", f"{lasers.shape} and {heights.shape}"
            )
        bad = [arm for arm in self.moved if arm not in ARMS]
        if bad:
            raise InvalidInputError("numcal data moved", "arms 'a', 'b' or 'c'", repr(bad[0]))
        if not (np.all(np.isfinite(lasers)) and np.all(np.isfinite(heights))):
            raise InvalidInputError("numcal data", "finite lasers and heights", "NaN or inf")
        moved_index = np.array([ARMS.index(arm) for arm in self.moved], dtype=int)
        if self.pivot_heights is None:
            pivots = np.zeros((count, 3))
            pivots[np.arange(count), moved_index] = heights
        else:
            pivots = np.asarray(self.pivot_heights, dtype=float)
            if pivots.shape != (count, 3) or not np.all(np.isfinite(pivots)):
                raise InvalidInputError("numcal data pivot_heights", f"finite values of shape ({count}, 3)",
                                        f"shape {pivots.shape}")
            if not np.array_equal(pivots[np.arange(count), moved_index], heights):
                raise InvalidInputError("numcal data heights", "the moved arm's column of pivot_heights",
                                        "different values")
        object.__setattr__(self, "lasers", lasers)
        object.__setattr__(self, "heights", heights)
        object.__setattr__(self, "pivot_heights", pivots)

    def subset(self, arms: tuple[str, ...]) -> NumcalData:
        """The samples where one of ``arms`` was moved."""
        keep = np.array([arm in arms for arm in self.moved], dtype=bool)
        return self.take(np.flatnonzero(keep))

    def take(self, indices: ArrayLike) -> NumcalData:
        """The samples ``indices`` (in that order)."""
        chosen = np.asarray(indices, dtype=int).reshape(-1)
        pivots = np.asarray(self.pivot_heights)
        return NumcalData(tuple(self.moved[k] for k in chosen), self.lasers[chosen], self.heights[chosen],
                          pivots[chosen])


_HEADER = ("moved", "laser_a", "laser_b", "laser_c", "height")
_HEADER_ALL = ("moved", "laser_a", "laser_b", "laser_c", "height_a", "height_b", "height_c")


def read_numcal_csv(path: str | Path) -> NumcalData:
    """Read ``moved,laser_a,laser_b,laser_c,height`` rows (mm), or ``...,height_a,height_b,height_c``.

    Raises
    ------
    FileFormatError
        Wrong header or field count, unknown arm, non-numeric value (with line).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "n.csv"
    >>> _ = f.write_text("moved,laser_a,laser_b,laser_c,height\\na,30,31,32,0\\nb,30,33,32,5.5\\n")
    >>> read_numcal_csv(f).heights.tolist()
    [0.0, 5.5]
    """
    file = Path(path)
    from pcmm_geo.io.text import read_csv_rows

    def check_header(line: int | None, cells: tuple[str, ...] | None) -> None:  # before the rest is read
        if cells is None or tuple(f.strip().lower() for f in cells) not in (_HEADER, _HEADER_ALL):
            got = excerpt(",".join(cells)) if cells is not None else "an empty file"
            raise FileFormatError(str(file), f"expected header {','.join(_HEADER)!r} or {','.join(_HEADER_ALL)!r}, "
                                  f"got {got}", line)

    rows = read_csv_rows(file, check_header=check_header).rows
    if not rows:
        check_header(None, None)
    width = len(rows[0][1])
    moved, values = [], []
    for number, cells in rows[1:]:
        fields = [f.strip() for f in cells]
        if len(fields) != width:
            raise FileFormatError(str(file), f"expected {width} fields, got {len(fields)}", number)
        if fields[0].lower() not in ARMS:
            raise FileFormatError(str(file), f"moved: expected a, b or c, got {excerpt(fields[0])}", number)
        try:
            row = [parse_decimal(f) for f in fields[1:]]
        except ValueError:
            raise FileFormatError(str(file), f"expected numbers, got {excerpt(','.join(fields[1:]))}", number) from None
        if not np.all(np.isfinite(row)):
            raise FileFormatError(str(file), f"expected finite numbers, got {excerpt(','.join(fields[1:]))}", number)
        moved.append(fields[0].lower())
        values.append(row)
    if not values:
        raise FileFormatError(str(file), "expected data rows, got none")
    arr = np.array(values)
    if width == len(_HEADER):
        return NumcalData(tuple(moved), arr[:, :3], arr[:, 3])
    index = np.array([ARMS.index(arm) for arm in moved])
    return NumcalData(tuple(moved), arr[:, :3], arr[np.arange(len(moved)), 3 + index], arr[:, 3:6])


def write_numcal_csv(data: NumcalData, path: str | Path, *, all_heights: bool | None = None) -> Path:
    """Write ``data`` in the format :func:`read_numcal_csv` reads (numbers in full precision).

    ``all_heights`` chooses the header with three pivot heights; default: only when a sample
    has a pivot other than the moved one away from the level start.  An existing file is
    refused (:class:`~pcmm_geo.errors.OutputExistsError`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> data = synthesise_numcal_data(NumcalParameters.from_seed_table(), samples_per_arm=2)
    >>> path = write_numcal_csv(data, pathlib.Path(tempfile.mkdtemp()) / "n.csv")
    >>> back = read_numcal_csv(path)
    >>> back.moved == data.moved, bool(np.array_equal(back.lasers, data.lasers))
    (True, True)
    """
    from pcmm_geo.errors import OutputExistsError

    file = Path(path)
    pivots = np.asarray(data.pivot_heights)
    moved_index = np.array([ARMS.index(arm) for arm in data.moved], dtype=int)
    others = pivots.copy()
    others[np.arange(len(data.moved)), moved_index] = 0.0
    wide = bool(np.any(others != 0.0)) if all_heights is None else all_heights
    lines = [",".join(_HEADER_ALL if wide else _HEADER)]
    for k, arm in enumerate(data.moved):
        values = [*data.lasers[k].tolist(), *(pivots[k].tolist() if wide else [float(data.heights[k])])]
        lines.append(",".join([arm, *(repr(float(v)) for v in values)]))
    try:
        with file.open("x", encoding="utf-8") as handle:
            handle.write("\n".join(lines) + "\n")
    except FileExistsError:
        raise OutputExistsError(str(file)) from None
    return file


def numcal_machine(truth: NumcalParameters) -> object:
    """The rigid-body machine whose height-gauge readings follow ``truth`` exactly.

    Slider lines meet at the tip with the angles ``truth.beta`` and slider offsets
    ``60 + truth.d``; vertical columns stand on a triangle with sides ``truth.b`` (arms
    clockwise seen from above, centroid at the origin).  Returns a
    :class:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine`.

    Raises
    ------
    InvalidInputError
        The three ``b`` violate the triangle inequality.

    Examples
    --------
    >>> machine = numcal_machine(NumcalParameters.from_seed_table())
    >>> pivots = machine.pivots([100.0, 100.0, 100.0])
    >>> round(float(np.linalg.norm(pivots[0] - pivots[1])), 6)  # b_ab of Table 7.1
    454.17
    """
    from pcmm_geo.machine.kinematics.limits import COLUMN_TRAVEL, MachineLimits
    from pcmm_geo.machine.kinematics.model import seed_machine

    ab, bc, ca = (truth.b[pair] for pair in ("ab", "bc", "ca"))
    if not (ab < bc + ca and bc < ab + ca and ca < ab + bc):
        raise InvalidInputError("b", "three pivot spacings that form a triangle", f"{ab}, {bc}, {ca}")
    along = (ab**2 + ca**2 - bc**2) / (2.0 * ab)
    corners = np.array([[0.0, 0.0], [ab, 0.0], [along, -np.sqrt(ca**2 - along**2)]])  # a, b, c clockwise
    corners -= corners.mean(axis=0)
    return seed_machine(
        dead_distance=dict(truth.d), beta_deg=truth.beta_deg,
        column_points={arm: tuple(corners[k]) for k, arm in enumerate(ARMS)},
        reference_height=LEVEL_START_HEIGHT,
        # the synthetic experiments count heights from home: travel 0-450 mm (thesis 3.1)
        limits=MachineLimits(height_travel=[0.0, COLUMN_TRAVEL]),
    )


def synthesise_design_data(
    truth: NumcalParameters,
    pivot_heights: ArrayLike,
    *,
    laser_sigma: float = 0.0,
    height_sigma: float = 0.0,
    seed: int = 0,
) -> NumcalData:
    """Readings of a rigid-body machine (:func:`numcal_machine`) at given pivot heights.

    Parameters
    ----------
    truth : NumcalParameters
    pivot_heights : array_like, shape (M, 3)
        Heights of pivots a, b, c relative to the level start (mm).
    laser_sigma, height_sigma : float
        Standard deviations of seeded Gaussian noise added to the lasers and heights (mm).
    seed : int

    Returns
    -------
    NumcalData
        ``moved`` is the arm whose pivot is highest above the lowest one in each sample.

    Raises
    ------
    InvalidInputError
        Heights not (M, 3) finite, or a pose the kinematics cannot solve.
    """
    heights = np.asarray(pivot_heights, dtype=float)
    if heights.ndim != 2 or heights.shape[1] != 3 or not np.all(np.isfinite(heights)):
        raise InvalidInputError("pivot_heights", "finite heights of shape (M, 3)", f"shape {heights.shape}")
    machine = numcal_machine(truth)
    solution = machine.forward(heights=LEVEL_START_HEIGHT + heights)  # type: ignore[attr-defined]
    if not np.all(solution.converged):
        raise InvalidInputError("pivot_heights", "poses the rigid-body model can solve", "no solution")
    rng = np.random.default_rng(seed)
    lasers = np.array(solution.lasers, dtype=float) + (rng.normal(0.0, laser_sigma, heights.shape)
                                                      if laser_sigma else 0.0)
    noisy = heights + (rng.normal(0.0, height_sigma, heights.shape) if height_sigma else 0.0)
    moved_index = np.argmax(heights - heights.min(axis=1, keepdims=True), axis=1)
    moved = tuple(ARMS[k] for k in moved_index)
    return NumcalData(moved, lasers, noisy[np.arange(len(moved)), moved_index], noisy)


def synthesise_numcal_data(
    truth: NumcalParameters,
    *,
    samples_per_arm: int = 15,
    max_height: float = 50.0,
    arms: tuple[str, ...] = ARMS,
    laser_sigma: float = 0.0,
    height_sigma: float = 0.0,
    seed: int = 0,
) -> NumcalData:
    """The seed's experiment with known truth: one pivot at a time raised from the level start.

    For each arm in ``arms``, its pivot is raised from 0 to ``max_height`` in
    ``samples_per_arm`` equal steps (Table 6.3: 15 samples per arm, about 50 mm) while the two
    others stand at the level start; the lasers are those of the rigid-body machine
    :func:`numcal_machine` (so the two other lasers also change, by about 1.6 um over 50 mm
    for Table 7.1's geometry, as the tetrahedron tilts).  Seeded Gaussian noise is added
    afterwards.

    Raises
    ------
    InvalidInputError
        Unknown arm, fewer than one sample, or a pose the kinematics cannot solve.

    Examples
    --------
    >>> data = synthesise_numcal_data(NumcalParameters.from_seed_table(), samples_per_arm=3)
    >>> data.moved
    ('a', 'a', 'a', 'b', 'b', 'b', 'c', 'c', 'c')
    >>> change = data.lasers[2] - data.lasers[0]  # arm a raised by 50 mm
    >>> round(float(change[0]), 3), bool(abs(change[2]) < 2e-3)
    (4.835, True)
    """
    if samples_per_arm < 1 or any(arm not in ARMS for arm in arms):
        raise InvalidInputError("synthesise_numcal_data", "samples_per_arm >= 1 and arms among a, b, c",
                                f"{samples_per_arm}, {arms}")
    steps = np.linspace(0.0, max_height, samples_per_arm)
    design = np.zeros((samples_per_arm * len(arms), 3))
    for block, arm in enumerate(arms):
        design[block * samples_per_arm : (block + 1) * samples_per_arm, ARMS.index(arm)] = steps
    data = synthesise_design_data(truth, design, laser_sigma=laser_sigma, height_sigma=height_sigma, seed=seed)
    moved = tuple(arm for arm in arms for _ in range(samples_per_arm))
    return NumcalData(moved, data.lasers, np.asarray(data.pivot_heights)[np.arange(len(moved)),
                                                                            [ARMS.index(a) for a in moved]],
                      data.pivot_heights)
