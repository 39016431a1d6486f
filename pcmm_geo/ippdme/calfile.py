"""The server's calibrated machine read from a ``pcmm calibrate --out`` file (``pcmm serve --calibration``).

A calibration file (:mod:`pcmm_geo.machine.calibration.calfile`) gives the calibrated
tetrahedron and tip radius; its ``machine`` entry (written with column lines) gives the whole
rigid-body model, otherwise the tetrahedron stands on the seed's nominal columns and reference
pose (as ``pcmm uncertainty --calibration`` takes it).  Its ``covariance`` entry (``pcmm calibrate
--probing-u-mm U --laser-u-mm U``) is the calibration's uncertainty that the simulated backend
draws its true machine from; a file without one serves a simulated machine whose truth is the
calibrated model (no calibration error), and says so.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.ippdme.machine import MachineModel

__all__ = ["ServedCalibration", "model_from_calibration"]


@record
class ServedCalibration:
    """The calibrated machine a server runs on.

    Attributes
    ----------
    model : MachineModel
    center : ndarray, shape (3,)
        Tip centre at the model's reference heights (mm): the middle of the working volume.
    source : str
        Where the model comes from (for the transcript header and the report).
    has_covariance : bool
        Whether the calibration's uncertainty is known.
    """

    model: MachineModel
    center: NDArray[np.float64]
    source: str
    has_covariance: bool


def model_from_calibration(path: str | os.PathLike[str], *, laser_sigma: float = 0.0005,
                           encoder_sigma: float = 0.0002) -> ServedCalibration:
    """The calibrated machine of a calibration file.

    Parameters
    ----------
    path : path-like
        A file written by ``pcmm calibrate --out`` (:func:`~pcmm_geo.machine.calibration.save_calibration`).
    laser_sigma, encoder_sigma : float
        Standard uncertainty of a laser / height reading (mm).

    Raises
    ------
    FileFormatError
        Not a calibration file, a damaged entry (named by its JSON path), no calibrated tip
        radius (element-level tip probings), or a covariance that does not fit the model.
    OSError
        The file cannot be read.
    """
    from pcmm_geo.errors import FileFormatError, InvalidInputError
    from pcmm_geo.machine.calibration.calfile import load_calibration, load_covariance, load_stored_machine
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    from pcmm_geo.uncertainty.calibration import CalibrationCovariance

    name = os.fspath(path)
    cal = load_calibration(name)
    radius = float(cal.tip.radius)
    if not (np.isfinite(radius) and radius > 0):
        raise FileFormatError(name, "expected a calibrated tip radius (raw tip probings), got none")
    machine: Any = load_stored_machine(name)  # a damaged machine entry is an error, not a fallback
    source = name
    if machine is None:
        nominal = RigidBodyMachine.from_dpkm()
        machine = RigidBodyMachine(cal.tetrahedron, nominal.columns, nominal.reference_lasers,
                                   nominal.reference_heights)
        source = f"{name} (tetrahedron on the seed's nominal columns)"
    entry = load_covariance(name)
    covariance = None
    if entry is not None:
        try:
            covariance = CalibrationCovariance.from_dict(entry).model_covariance()[1]
        except InvalidInputError as exc:
            raise FileFormatError(name, f"covariance: {exc}") from None
    solution = machine.forward(heights=machine.reference_heights, lasers_hint=machine.reference_lasers,
                               check_limits=False)
    if not np.all(solution.converged):
        raise FileFormatError(name, "expected a machine whose reference pose solves, got one that does not")
    model = MachineModel(machine, radius, covariance, laser_sigma=laser_sigma, encoder_sigma=encoder_sigma)
    return ServedCalibration(model, np.asarray(solution.tip, dtype=float).reshape(3), source, covariance is not None)
