"""pcmm_geo: geometric metrology for coordinate measuring machines.

Sub-packages (data flows down, nothing below imports from above; docs/architecture.md):

- :mod:`pcmm_geo.elements` -- the one table of the geometric elements and fit criteria
  (``Element``, ``Criterion``) that every other layer reads.
- :mod:`pcmm_geo.fit` -- Gaussian least-squares fits of geometric elements, skew lines,
  reference-data generator (pure numpy/scipy).
- :mod:`pcmm_geo.thermal` -- expansion model, RTD / thermistor conversions, 20 degC correction.
- :mod:`pcmm_geo.machine` -- the parallel-mechanism micro-CMM: kinematics, calibration,
  log processing and sensitivity (sub-packages ``kinematics``, ``calibration``, ``analysis``).
- :mod:`pcmm_geo.acquisition` -- serial drivers, device simulators, sessions, durable logs.
- :mod:`pcmm_geo.artefacts` -- gauge blocks, ISO 10360-2/-5/-6 evaluations.
- :mod:`pcmm_geo.io` -- point, mesh and CSV file formats.
- :mod:`pcmm_geo.testing` -- helpers for users' own tests.

Units: millimetres and radians inside; degrees only where named ``*_deg``.

Install: ``pip install pcmm_geo`` needs numpy and scipy only; extras ``[cad]`` (open3d,
trimesh), ``[acquire]`` (pyserial), ``[plots]`` (matplotlib), ``[progress]`` (rich),
``[dask]`` and ``[all]``.  A function that needs a missing extra raises
:class:`MissingDependencyError` naming it (see :func:`require`).
"""

from __future__ import annotations

from pcmm_geo._optional import require
from pcmm_geo.errors import (
    AmbiguousFitError,
    AmbiguousFitWarning,
    CalibrationError,
    CalibrationNotConvergedWarning,
    ConvergenceError,
    DegenerateGeometryError,
    DeviceError,
    DeviceProtocolError,
    DeviceTimeoutError,
    FileFormatError,
    IllConditionedWarning,
    IncompleteTestError,
    InconsistentMeasurementError,
    InvalidInputError,
    LogIntegrityError,
    MissingDependencyError,
    NoRealSolutionError,
    OutOfRangeError,
    OutputExistsError,
    PcmmGeoError,
    PcmmGeoWarning,
    QifError,
    TooFewPointsError,
    UnassuredMinimumWarning,
    UnsafeXmlError,
)

__version__ = "0.2.0.dev0"

__all__ = [
    "__version__",
    "PcmmGeoError",
    "PcmmGeoWarning",
    "InvalidInputError",
    "TooFewPointsError",
    "DegenerateGeometryError",
    "AmbiguousFitError",
    "AmbiguousFitWarning",
    "UnassuredMinimumWarning",
    "ConvergenceError",
    "NoRealSolutionError",
    "OutputExistsError",
    "MissingDependencyError",
    "FileFormatError",
    "QifError",
    "UnsafeXmlError",
    "CalibrationError",
    "DeviceError",
    "DeviceTimeoutError",
    "DeviceProtocolError",
    "LogIntegrityError",
    "IncompleteTestError",
    "OutOfRangeError",
    "InconsistentMeasurementError",
    "IllConditionedWarning",
    "CalibrationNotConvergedWarning",
    "require",
]
