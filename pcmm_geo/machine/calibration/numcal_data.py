"""Data and parameters of the numerical calibration (thesis ch. 6): the height-gauge experiment.

See :mod:`pcmm_geo.machine.calibration.numcal` for the model and the solvers.  CSV format of the
experiment: header ``moved,laser_a,laser_b,laser_c,height`` (mm); ``moved`` is the arm
whose pivot bracket was moved, ``height`` the height-gauge reading of that pivot
relative to the level start.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.io._text import excerpt, parse_decimal

__all__ = [
    "MOVED_PAIR",
    "PARAMETER_NAMES",
    "SEED_BOUNDS",
    "NumcalData",
    "NumcalParameters",
    "read_numcal_csv",
    "synthesise_numcal_data",
]

FloatArray = NDArray[np.float64]
ARMS = ("a", "b", "c")
PARAMETER_NAMES = ("d_a", "d_b", "d_c", "beta_ab", "beta_bc", "beta_ca", "b_ab", "b_bc", "b_ca")
#: moved arm -> (stationary arm i, moved arm in, pair name)
MOVED_PAIR = {"a": ("c", "a", "ca"), "b": ("a", "b", "ab"), "c": ("b", "c", "bc")}
_PAIR_INDEX = {"ab": 0, "bc": 1, "ca": 2}
#: Appendix B's GA bounds: d 300-400 mm, beta 60-80 degrees, b 400-500 mm (beta in radians here)
SEED_BOUNDS = (
    np.array([300.0] * 3 + [np.radians(60.0)] * 3 + [400.0] * 3),
    np.array([400.0] * 3 + [np.radians(80.0)] * 3 + [500.0] * 3),
)
START_OF_RANGE = 60.0


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


@dataclass(frozen=True)
class NumcalData:
    """Height-gauge experiment (thesis 6.2): per sample the moved arm, three lasers and the height.

    Attributes
    ----------
    moved : tuple of str
        Arm moved for each sample (``'a'``, ``'b'`` or ``'c'``), length M.
    lasers : ndarray, shape (M, 3)
        Laser readings a, b, c (mm, without the 60 mm start of range).
    heights : ndarray, shape (M,)
        Height-gauge reading of the moved pivot relative to the level start (mm).
    """

    moved: tuple[str, ...]
    lasers: FloatArray
    heights: FloatArray

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
        object.__setattr__(self, "lasers", lasers)
        object.__setattr__(self, "heights", heights)

    def subset(self, arms: tuple[str, ...]) -> NumcalData:
        """The samples where one of ``arms`` was moved."""
        keep = np.array([arm in arms for arm in self.moved])
        return NumcalData(tuple(np.array(self.moved)[keep]), self.lasers[keep], self.heights[keep])


def read_numcal_csv(path: str | Path) -> NumcalData:
    """Read ``moved,laser_a,laser_b,laser_c,height`` rows (mm).

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
    from pcmm_geo.io._text import read_text_lines

    lines = [(n, raw.strip()) for n, raw in read_text_lines(file)]
    lines = [(n, text) for n, text in lines if text and not text.startswith("#")]
    header = ("moved", "laser_a", "laser_b", "laser_c", "height")
    if not lines or tuple(f.strip().lower() for f in lines[0][1].split(",")) != header:
        got = lines[0][1] if lines else "an empty file"
        raise FileFormatError(str(file), f"expected header {','.join(header)!r}, got {got!r}", lines[0][0] if lines
                              else None)
    moved, values = [], []
    for number, text in lines[1:]:
        fields = [f.strip() for f in text.split(",")]
        if len(fields) != 5:
            raise FileFormatError(str(file), f"expected 5 fields, got {len(fields)}", number)
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
    return NumcalData(tuple(moved), arr[:, :3], arr[:, 3])


def synthesise_numcal_data(
    truth: NumcalParameters,
    *,
    samples_per_arm: int = 15,
    max_height: float = 50.0,
    stationary_gain: float = 0.05,
    start_lasers: ArrayLike = (34.0, 33.0, 37.0),
    laser_sigma: float = 0.0,
    height_sigma: float = 0.0,
    seed: int = 0,
) -> NumcalData:
    """Height-gauge data of known truth (the seed's experiment, 15 samples per arm as Table 6.3).

    For each moved arm the height runs from 0 to ``max_height``; the stationary arm's
    length drifts by ``stationary_gain`` mm per mm of height and the moved arm's length
    solves eqs 2.5/2.7 exactly; seeded Gaussian noise is added afterwards.

    Raises
    ------
    InvalidInputError
        A geometry with no real solution (b < L_i sin beta).

    Examples
    --------
    >>> data = synthesise_numcal_data(NumcalParameters.from_seed_table(), samples_per_arm=3)
    >>> data.moved
    ('a', 'a', 'a', 'b', 'b', 'b', 'c', 'c', 'c')
    """
    rng = np.random.default_rng(seed)
    p = truth.vector()
    start = np.asarray(start_lasers, dtype=float)
    heights = np.linspace(0.0, max_height, samples_per_arm)
    moved: list[str] = []
    lasers: list[FloatArray] = []
    for arm in ARMS:
        i_arm, n_arm, pair = MOVED_PAIR[arm]
        i, n, k = ARMS.index(i_arm), ARMS.index(n_arm), _PAIR_INDEX[pair]
        length_i = start[i] + START_OF_RANGE + p[i] + stationary_gain * heights
        cosine = np.cos(p[3 + k])
        disc = length_i**2 * cosine**2 - length_i**2 + heights**2 + p[6 + k] ** 2
        if np.any(disc < 0):
            raise InvalidInputError("truth", "b_in > L_i sin(beta_in) for every sample", "no real moved-arm length")
        length_n = length_i * cosine + np.sqrt(disc)
        for h in range(samples_per_arm):
            reading = start.copy()
            reading[i] = length_i[h] - START_OF_RANGE - p[i]
            reading[n] = length_n[h] - START_OF_RANGE - p[n]
            lasers.append(reading)
            moved.append(arm)
    laser_array = np.array(lasers) + rng.normal(0.0, laser_sigma, (len(moved), 3)) if laser_sigma else np.array(lasers)
    height_array = np.tile(heights, 3)
    if height_sigma:
        height_array = height_array + rng.normal(0.0, height_sigma, height_array.size)
    return NumcalData(tuple(moved), laser_array, height_array)


