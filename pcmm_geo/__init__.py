"""pcmm_geo: geometric metrology for coordinate measuring machines.

Sub-packages (data flows down, nothing below imports from above; docs/architecture.md):

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
"""

from __future__ import annotations

from pcmm_geo.errors import (
    AmbiguousFitError,
    AmbiguousFitWarning,
    CalibrationError,
    ConvergenceError,
    DegenerateGeometryError,
    DeviceError,
    DeviceProtocolError,
    DeviceTimeoutError,
    FileFormatError,
    IllConditionedWarning,
    IncompleteTestError,
    InvalidInputError,
    LogIntegrityError,
    NoRealSolutionError,
    OutputExistsError,
    PcmmGeoError,
    PcmmGeoWarning,
    TooFewPointsError,
)

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "PcmmGeoError",
    "PcmmGeoWarning",
    "InvalidInputError",
    "TooFewPointsError",
    "DegenerateGeometryError",
    "AmbiguousFitError",
    "AmbiguousFitWarning",
    "ConvergenceError",
    "NoRealSolutionError",
    "OutputExistsError",
    "FileFormatError",
    "CalibrationError",
    "DeviceError",
    "DeviceTimeoutError",
    "DeviceProtocolError",
    "LogIntegrityError",
    "IncompleteTestError",
    "IllConditionedWarning",
]
