"""Uncertainty of the tetrahedron calibration (thesis ch. 7) from the external CMM and the lasers.

Inputs ``x`` and their covariance ``U_x``:

* every probed ball center (joints at each slider position, and the tip) with the
  covariance of its Gaussian sphere fit for the stated probing uncertainty ``sigma_p`` of
  the external CMM: ``sigma_p^2 (J^T J)^-1`` with the fit's Jacobian ``J`` (rows
  ``(-n_j, -1)``, ``n_j`` the unit normal at point j), which depends on how the points
  cover the ball (a 3/4 cap gives a worse vertical than horizontal center);  the tip ball's
  radius comes with its center (it is used for probe-radius compensation);
* the laser readings at the slider positions, ``u = sigma_L`` each, independent.

Outputs ``theta``: per arm the slider line (point, direction), laser scale and offset; the
tip center and radius; the seed's dead distances and arm angles ``beta`` (radians).  The
covariance ``U_theta = J U_x J^T`` uses the Jacobian of the *whole* calibration
(:func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron`, line fits, regressions, the
foot-point construction) by central differences with steps of a tenth of each input's
uncertainty (:func:`calibration_covariance`).  :func:`calibration_covariance_monte_carlo`
re-noises the raw probed points and lasers and recalibrates (JCGM 101) -- the test suite
shows both agree, i.e. the calibration is linear over its input uncertainties.

A point and direction per line over-parametrise it (6 numbers for 4 degrees of freedom),
so ``U_theta`` is singular; sample it with :func:`~pcmm_geo.uncertainty.montecarlo.sample_normal`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError

__all__ = [
    "MODEL_PARAMETERS",
    "PARAMETER_NAMES",
    "CalibrationCovariance",
    "calibration_covariance",
    "calibration_covariance_monte_carlo",
    "calibration_parameters",
    "sphere_fit_covariance",
]

FloatArray = NDArray[np.float64]
_ARMS = ("a", "b", "c")
_PAIRS = ("ab", "bc", "ca")
#: parameters of the rigid-body tetrahedron (used by the virtual CMM), in order
_SLIDER = ("point_x", "point_y", "point_z", "direction_x", "direction_y", "direction_z", "laser_scale", "laser_offset")
MODEL_PARAMETERS: tuple[str, ...] = (
    *(f"slider_{arm}.{name}" for arm in _ARMS for name in _SLIDER),
    "tip_center_x", "tip_center_y", "tip_center_z", "tip_radius",
)
#: all calibrated parameters with a covariance: the model's plus the seed's d (mm) and beta (rad)
PARAMETER_NAMES: tuple[str, ...] = (
    *MODEL_PARAMETERS, *(f"dead_distance_{a}" for a in _ARMS), *(f"beta_{p}" for p in _PAIRS)
)


def _center_field(sphere: Any) -> str:
    """Name of a fitted sphere's center field: ``center``, or the British spelling before issue 15a's rename."""
    names = {f.name for f in dataclasses.fields(sphere)}
    return "center" if "center" in names else "centre"


def _center_of(sphere: Any) -> FloatArray:
    return np.asarray(getattr(sphere, _center_field(sphere)), dtype=float)


def _with_center(sphere: Any, center: FloatArray) -> Any:
    return dataclasses.replace(sphere, **{_center_field(sphere): center})


def _unit(name: str) -> str:
    if name.startswith("beta_"):
        return "rad"
    if "direction" in name or "laser_scale" in name:
        return "1"
    return "mm"


def calibration_parameters(cal: Any) -> FloatArray:
    """The vector of :data:`PARAMETER_NAMES` of a :class:`TetrahedronCalibration` (mm, rad, 1)."""
    values: list[float] = []
    for arm in _ARMS:
        line = cal.slider_lines[arm]
        values += [*np.asarray(line.point, float), *np.asarray(line.direction, float)]
        values += [float(line.laser_scale), float(line.laser_offset)]
    values += [*np.asarray(_center_of(cal.tip), float), float(cal.tip.radius)]
    values += [float(cal.dead_distance[arm]) for arm in _ARMS]
    values += [math.radians(float(cal.beta_deg[pair])) for pair in _PAIRS]
    return np.array(values)


def sphere_fit_covariance(points: Any, center: Any, sigma: float) -> FloatArray:
    """Covariance (4, 4) of (center x, y, z, radius) of a Gaussian sphere fit for point noise ``sigma``.

    First order: ``sigma^2 (J^T J)^-1`` with rows ``J_j = (-(p_j - c)/|p_j - c|, -1)``.

    Examples
    --------
    Six points at the poles of a unit sphere, sigma = 0.001:

    >>> pts = np.vstack([np.eye(3), -np.eye(3)])
    >>> cov = sphere_fit_covariance(pts, np.zeros(3), 0.001)
    >>> np.round(np.sqrt(np.diag(cov)) * 1e3, 4).tolist()
    [0.7071, 0.7071, 0.7071, 0.4082]
    """
    pts = np.asarray(points, dtype=float)
    normals = pts - np.asarray(center, dtype=float)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    jac = np.column_stack([-normals, -np.ones(len(pts))])
    return sigma**2 * np.linalg.inv(jac.T @ jac)


@record
class CalibrationCovariance:
    """Calibrated parameters with their covariance.

    Attributes
    ----------
    names : tuple of str
        :data:`PARAMETER_NAMES`.
    values : ndarray, shape (p,)
    covariance : ndarray, shape (p, p)
        Units: mm, rad or 1 per parameter (:meth:`units`).
    method : str
        ``"GUM linear"`` (central-difference Jacobian) or ``"Monte Carlo"``.
    probing_sigma, laser_sigma : float
        The input uncertainties used (mm).
    n_trials : int
        Monte Carlo recalibrations (0 for GUM).
    jacobian : ndarray, shape (p, n) or None
        ``d theta / d x`` (GUM only; not stored in files).
    input_names : tuple of str
    input_covariance : ndarray, shape (n, n) or None
    """

    names: tuple[str, ...]
    values: FloatArray
    covariance: FloatArray
    method: str
    probing_sigma: float
    laser_sigma: float
    n_trials: int = 0
    jacobian: FloatArray | None = dataclasses.field(default=None, repr=False, compare=False)
    input_names: tuple[str, ...] = ()
    input_covariance: FloatArray | None = dataclasses.field(default=None, repr=False, compare=False)

    @property
    def standard_uncertainties(self) -> dict[str, float]:
        """``{name: u}`` (square roots of the diagonal)."""
        diag = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        diag = np.where(np.isfinite(self.values), diag, np.nan)  # e.g. no tip radius in element-level data
        return {name: float(u) for name, u in zip(self.names, diag, strict=True)}

    def units(self) -> dict[str, str]:
        """``{name: unit}``."""
        return {name: _unit(name) for name in self.names}

    def model_covariance(self) -> tuple[FloatArray, FloatArray]:
        """Values (28,) and covariance (28, 28) of :data:`MODEL_PARAMETERS` (tetrahedron and tip radius)."""
        index = [self.names.index(name) for name in MODEL_PARAMETERS]
        return self.values[index], self.covariance[np.ix_(index, index)]

    def table(self) -> list[dict[str, Any]]:
        """Rows ``{name, value, standard_uncertainty, unit}`` for reports."""
        u = self.standard_uncertainties
        return [
            {"name": n, "value": float(v), "standard_uncertainty": u[n], "unit": _unit(n)}
            for n, v in zip(self.names, self.values, strict=True)
        ]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form stored in calibration files under ``"covariance"``."""
        return {
            "names": list(self.names),
            "units": [_unit(n) for n in self.names],
            "values": self.values.tolist(),
            "matrix": self.covariance.tolist(),
            "method": self.method,
            "probing_sigma_mm": self.probing_sigma,
            "laser_sigma_mm": self.laser_sigma,
            "n_trials": self.n_trials,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> CalibrationCovariance:
        """Rebuild from :meth:`to_dict`.

        Raises
        ------
        InvalidInputError
            Missing keys or inconsistent shapes.
        """
        try:
            names = tuple(str(n) for n in data["names"])
            values = np.array([math.nan if v is None else v for v in data["values"]], dtype=float)
            matrix = np.asarray(data["matrix"], dtype=float)
            out = cls(names, values, matrix, str(data["method"]), float(data["probing_sigma_mm"]),
                      float(data["laser_sigma_mm"]), int(data.get("n_trials", 0)))
        except (KeyError, TypeError, ValueError) as exc:
            raise InvalidInputError("covariance", "names, values, matrix, method, sigmas", repr(exc)) from None
        if values.shape != (len(names),) or matrix.shape != (len(names), len(names)):
            raise InvalidInputError("covariance", f"{len(names)} values and a square matrix",
                                    f"shapes {values.shape}, {matrix.shape}")
        return out


def _inputs(features: Any, lasers: FloatArray, probing_sigma: float, laser_sigma: float) -> tuple[
    FloatArray, FloatArray, list[str]
]:
    """Input vector (ball centers, tip radius, lasers), its covariance and names."""
    positions = features.positions
    values: list[float] = []
    names: list[str] = []
    blocks: list[FloatArray] = []
    spheres = [(f"joint_{arm}[{pos}]", ("joint_" + arm, pos), features.joints[arm][pos])
               for arm in _ARMS for pos in positions]
    spheres.append(("tip", ("tip", None), features.tip))
    for label, key, sphere in spheres:
        points = features.points.get(key)
        if points is not None and len(points) >= 4:
            cov = sphere_fit_covariance(points, _center_of(sphere), probing_sigma)
        else:  # element-level data: the center is known to the probing uncertainty
            cov = np.diag([probing_sigma**2] * 3 + [probing_sigma**2])
        take = 4 if label == "tip" else 3
        values += [*np.asarray(_center_of(sphere), float)] + ([float(sphere.radius)] if take == 4 else [])
        names += [f"{label}.x", f"{label}.y", f"{label}.z"] + ([f"{label}.radius"] if take == 4 else [])
        blocks.append(cov[:take, :take])
    values += lasers.ravel().tolist()
    names += [f"laser_{arm}[{pos}]" for pos in positions for arm in _ARMS]
    blocks.append(np.eye(lasers.size) * laser_sigma**2)
    size = sum(len(b) for b in blocks)
    covariance = np.zeros((size, size))
    start = 0
    for block in blocks:
        covariance[start:start + len(block), start:start + len(block)] = block
        start += len(block)
    return np.array(values), covariance, names


def _rebuild(features: Any, x: FloatArray) -> tuple[Any, FloatArray]:
    from pcmm_geo.machine.calibration.probings import ProbedFeatures

    positions = features.positions
    at = 0
    joints: dict[str, dict[int, Any]] = {}
    for arm in _ARMS:
        joints[arm] = {}
        for pos in positions:
            joints[arm][pos] = _with_center(features.joints[arm][pos], x[at:at + 3].copy())
            at += 3
    tip = dataclasses.replace(_with_center(features.tip, x[at:at + 3].copy()), radius=float(x[at + 3]))
    at += 4
    lasers = x[at:].reshape(len(positions), 3)
    return ProbedFeatures(joints=joints, tip=tip, points={}, source=features.source), lasers


def _prepare(probings: Any, lasers: Any) -> tuple[Any, FloatArray]:
    from pcmm_geo.machine.calibration.tetrahedron import as_laser_table, as_probed_features

    features = as_probed_features(probings)
    table = as_laser_table(lasers, features.positions)
    return features, table.at(features.positions)


def _check_sigmas(probing_sigma: float, laser_sigma: float) -> None:
    for name, value in (("probing_sigma", probing_sigma), ("laser_sigma", laser_sigma)):
        if not (math.isfinite(value) and value >= 0):
            raise InvalidInputError(name, "a standard uncertainty >= 0 in mm", str(value))


def calibration_covariance(
    probings: Any,
    lasers: Any,
    *,
    probing_sigma: float,
    laser_sigma: float,
    **calibrate_options: Any,
) -> CalibrationCovariance:
    r"""Covariance of the calibrated parameters by the GUM's linear law through the whole calibration.

    Parameters
    ----------
    probings, lasers
        As for :func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron` (raw probed points
        are needed for the ball-center covariances; element-level data get ``probing_sigma``
        per center coordinate).
    probing_sigma : float
        Standard uncertainty of one external-CMM probing, per point (mm).
    laser_sigma : float
        Standard uncertainty of one laser reading at a calibration position (mm).
    **calibrate_options
        ``laser_start_of_range``, ``laser_scale`` passed on to the calibration.

    Returns
    -------
    CalibrationCovariance
        ``method = "GUM linear"``, with the Jacobian and the input covariance.

    See Also
    --------
    calibration_covariance_monte_carlo : the same covariance by re-noising and recalibrating
    pcmm_geo.uncertainty.gum.propagate_covariance : the linear law for vector outputs
    pcmm_geo.machine.calibration.tetrahedron.calibrate_tetrahedron

    Notes
    -----
    The law of propagation of uncertainty for a vector output (GUM 5.2 [1]_, JCGM 102 [2]_):

    .. math::

        U_\theta = J \, U_x \, J^\mathsf{T} , \qquad J = \frac{\partial \theta}{\partial x} ,

    with :math:`\theta` the calibrated parameters, :math:`x` the ball centres (their covariance
    from the sphere fits of the raw probed points) and the laser readings, and :math:`J` by
    central differences through the whole calibration.

    References
    ----------
    .. [1] JCGM 100:2008, *Evaluation of measurement data -- Guide to the expression of uncertainty in
           measurement* (GUM).
    .. [2] JCGM 102:2011, *Evaluation of measurement data -- Supplement 2 to the GUM -- Extension to any
           number of output quantities*.

    Examples
    --------
    >>> from pcmm_geo.demo import DemoSettings, simulate_probings, true_machine, CALIBRATION_LASERS
    >>> s = DemoSettings(seed=3)
    >>> probings = simulate_probings(true_machine(s), s, np.random.default_rng(3))
    >>> cov = calibration_covariance(probings, CALIBRATION_LASERS, probing_sigma=0.0005, laser_sigma=0.0005)
    >>> u = cov.standard_uncertainties
    >>> bool(0.0001 < u["slider_a.laser_offset"] < 0.01), bool(u["beta_ab"] < 1e-4)
    (True, True)
    """
    from pcmm_geo.machine.calibration import calibrate_tetrahedron
    from pcmm_geo.uncertainty.gum import jacobian

    _check_sigmas(probing_sigma, laser_sigma)
    features, readings = _prepare(probings, lasers)
    x0, cov_x, input_names = _inputs(features, readings, probing_sigma, laser_sigma)

    def model(x: FloatArray) -> FloatArray:
        feats, las = _rebuild(features, x)
        return calibration_parameters(calibrate_tetrahedron(feats, las, **calibrate_options))

    u_x = np.sqrt(np.diag(cov_x))
    steps = np.where(u_x > 0, u_x / 10.0, 1e-6 * np.maximum(1.0, np.abs(x0)))
    values, jac = jacobian(model, x0, steps)
    # a parameter the data do not give (the tip radius of element-level data) stays NaN with no covariance
    jac = np.where(np.isfinite(values)[:, None], np.nan_to_num(jac, nan=0.0), 0.0)
    covariance = jac @ cov_x @ jac.T
    return CalibrationCovariance(
        names=PARAMETER_NAMES,
        values=values,
        covariance=0.5 * (covariance + covariance.T),
        method="GUM linear",
        probing_sigma=float(probing_sigma),
        laser_sigma=float(laser_sigma),
        jacobian=jac,
        input_names=tuple(input_names),
        input_covariance=cov_x,
    )


def calibration_covariance_monte_carlo(
    probings: Any,
    lasers: Any,
    *,
    probing_sigma: float,
    laser_sigma: float,
    trials: int = 500,
    seed: int | np.random.Generator = 0,
    **calibrate_options: Any,
) -> CalibrationCovariance:
    r"""Covariance of the calibrated parameters by re-noising the raw points and lasers and recalibrating.

    Every trial adds ``N(0, probing_sigma^2)`` to each coordinate of every probed point and
    ``N(0, laser_sigma^2)`` to each laser reading, refits all balls (batched sphere fits) and
    recalibrates.  ``values`` are those of the unperturbed calibration.

    Raises
    ------
    InvalidInputError
        Element-level probings (no raw points to re-noise), or fewer than 10 trials.

    See Also
    --------
    calibration_covariance : the GUM linear evaluation


    Notes
    -----
    Propagation of distributions (JCGM 101 [1]_): the sample covariance of the recalibrated
    parameters :math:`\theta^{(k)}`, :math:`k = 1 \ldots M`,

    .. math::

        U_\theta = \frac{1}{M - 1} \sum_{k=1}^{M}
                   (\theta^{(k)} - \bar\theta)(\theta^{(k)} - \bar\theta)^\mathsf{T} ,

    which also holds where the calibration is not linear within the input uncertainties
    (JCGM 102 [2]_, section 7).


    References
    ----------
    .. [1] JCGM 101:2008, *Evaluation of measurement data -- Supplement 1 to the GUM -- Propagation of
           distributions using a Monte Carlo method*.
    .. [2] JCGM 102:2011, *Evaluation of measurement data -- Supplement 2 to the GUM -- Extension to any
           number of output quantities*.
    """
    from pcmm_geo.fit.batch import fit_spheres
    from pcmm_geo.machine.calibration import calibrate_tetrahedron
    from pcmm_geo.machine.calibration.geometry import FittedSphere
    from pcmm_geo.machine.calibration.probings import ProbedFeatures

    _check_sigmas(probing_sigma, laser_sigma)
    if trials < 10:
        raise InvalidInputError("trials", "at least 10 recalibrations", str(trials))
    features, readings = _prepare(probings, lasers)
    keys = [("joint_" + arm, pos) for arm in _ARMS for pos in features.positions] + [("tip", None)]
    if any(key not in features.points for key in keys):
        raise InvalidInputError("probings", "raw probed points for every ball", "element-level data")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    nominal = calibration_parameters(calibrate_tetrahedron(features, readings, **calibrate_options))
    fits = {}
    for key in keys:
        points = np.asarray(features.points[key], dtype=float)
        noisy = points + rng.normal(0.0, probing_sigma, (trials, *points.shape))
        fits[key] = fit_spheres(noisy)
    noisy_lasers = readings + rng.normal(0.0, laser_sigma, (trials, *readings.shape))
    samples = np.empty((trials, len(PARAMETER_NAMES)))
    for t in range(trials):
        def sphere(key: tuple[str, int | None], trial: int) -> FittedSphere:
            fit = fits[key]
            return FittedSphere(np.asarray(fit.centers[trial]), float(fit.radii[trial]), float(fit.form[trial]), fit.n)

        joints = {arm: {pos: sphere(("joint_" + arm, pos), t) for pos in features.positions} for arm in _ARMS}
        feats = ProbedFeatures(joints=joints, tip=sphere(("tip", None), t), points={}, source=features.source)
        samples[t] = calibration_parameters(calibrate_tetrahedron(feats, noisy_lasers[t], **calibrate_options))
    return CalibrationCovariance(
        names=PARAMETER_NAMES,
        values=nominal,
        covariance=np.cov(samples, rowvar=False),
        method="Monte Carlo",
        probing_sigma=float(probing_sigma),
        laser_sigma=float(laser_sigma),
        n_trials=trials,
    )
