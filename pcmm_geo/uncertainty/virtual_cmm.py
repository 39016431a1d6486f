"""Virtual micro-CMM: task-specific measurement uncertainty by simulation (ISO 15530-4 style).

A measurement task (:mod:`~pcmm_geo.uncertainty.tasks`) is simulated many times.  In
every trial the machine differs from the calibrated model within what is known about it
and the readings carry their noise; the same evaluation as the real measurement turns the
readings into the measured value.  The spread of the values is the task-specific
uncertainty.

Input groups (each drawn as independent standard normals ``z``, scaled here):

``calibration``
    The calibrated tetrahedron and tip radius, ``theta + L z`` with ``L L^T`` the
    covariance of :data:`~pcmm_geo.uncertainty.calibration.MODEL_PARAMETERS`
    (:func:`~pcmm_geo.uncertainty.calibration.calibration_covariance`).
``laser_noise``, ``encoder_noise``
    Every reading of every contact, ``sigma_L`` and ``sigma_H`` (mm).
``probing``
    Scatter of the probe's trigger point along the surface normal, ``sigma_P`` (mm).
``thermal_machine``
    Residual temperature errors of the three arms and the three columns after the
    machine's temperature correction (``u`` in K each, independent) and the uncertainty
    of their expansion coefficient at the mean machine temperature: arms lengthen about
    the tip and columns from their base (the model of
    :func:`pcmm_geo.thermal.expand_rigid_body_machine`, linear in ``alpha dT``).
``thermal_workpiece``
    The artefact's temperature and expansion coefficient: the value is corrected to
    20 °C with the *stated* ones (:func:`pcmm_geo.thermal.correct_length`) while the
    artefact follows the true ones.

Readings are those of the calibrated model at the nominal contacts (its inverse
kinematics); in each trial the perturbed machine turns them into tip centres
(:func:`~pcmm_geo.uncertainty.kinematics.forward_batch`), which are compensated for the
(perturbed) tip radius along the approach direction.  The simulated values scatter about
the nominal; :meth:`TaskUncertainty.interval_about` places the interval about a real
measured value.

The budget runs the simulation with one group varied at a time.  The GUM alternative
(:meth:`VirtualCMM.gum`) differentiates the same simulation with respect to every ``z``
(central differences, all ``2n`` evaluations in one batch) and sums ``c_i^2``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import ConvergenceError, InvalidInputError
from pcmm_geo.thermal.expansion import ALPHA_ALUMINIUM, ALPHA_GAUGE_BLOCK_STEEL, REFERENCE_TEMPERATURE
from pcmm_geo.uncertainty.kinematics import BatchGeometry, forward_batch
from pcmm_geo.uncertainty.result import BudgetEntry, UncertaintyResult
from pcmm_geo.uncertainty.tasks import MeasurementTask

__all__ = ["GROUPS", "GROUP_LABELS", "TaskUncertainty", "ThermalInputs", "VirtualCMM"]

FloatArray = NDArray[np.float64]
GROUPS = ("calibration", "laser_noise", "encoder_noise", "probing", "thermal_machine", "thermal_workpiece")
#: what each input group is, in words, for budgets people read (tables, plots, reports)
GROUP_LABELS = {
    "calibration": "calibrated geometry",
    "laser_noise": "laser readings",
    "encoder_noise": "height (encoder) readings",
    "probing": "probing scatter",
    "thermal_machine": "machine temperature",
    "thermal_workpiece": "workpiece temperature and expansion",
}
#: trials per chunk of the kinematics (bounds memory: about 60 kB per trial and contact)
CHUNK = 10_000


@dataclass(frozen=True)
class ThermalInputs:
    """Thermal state of the machine and the workpiece with the uncertainties of its inputs.

    Attributes
    ----------
    arm_temperature_u, column_temperature_u : float
        Standard uncertainty of each arm's / column's temperature after correction (K).
    machine_temperature : float
        Mean machine temperature (°C); with ``alpha_machine_u`` it gives the uncertainty of
        the expansion correction ``u(alpha) |T - 20|``.
    alpha_machine, alpha_machine_u : float
        Expansion coefficient of arms and columns and its uncertainty (1/K).
    workpiece_temperature, workpiece_temperature_u : float
        Artefact temperature (°C) and its standard uncertainty (K).
    alpha_workpiece, alpha_workpiece_u : float
        Artefact expansion coefficient and its uncertainty (1/K); default steel gauge block
        (ISO 3650: (11.5 +- 1.0) 1e-6/K).
    """

    arm_temperature_u: float = 0.0
    column_temperature_u: float = 0.0
    machine_temperature: float = REFERENCE_TEMPERATURE
    alpha_machine: float = ALPHA_ALUMINIUM
    alpha_machine_u: float = 0.0
    workpiece_temperature: float = REFERENCE_TEMPERATURE
    workpiece_temperature_u: float = 0.0
    alpha_workpiece: float = ALPHA_GAUGE_BLOCK_STEEL
    alpha_workpiece_u: float = 0.0

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if not math.isfinite(value) or (name.endswith("_u") and value < 0):
                raise InvalidInputError(name, "a finite value (uncertainties >= 0)", str(value))

    @property
    def machine_active(self) -> bool:
        return bool(self.arm_temperature_u or self.column_temperature_u or self.alpha_machine_u)

    @property
    def workpiece_active(self) -> bool:
        return bool(self.workpiece_temperature_u or self.alpha_workpiece_u)


@dataclass(frozen=True)
class TaskUncertainty:
    """Task-specific uncertainty from :meth:`VirtualCMM.evaluate`.

    Attributes
    ----------
    task : str
    quantity : str
    nominal : float
        Nominal value of the measurand (mm).
    result : UncertaintyResult
        The Monte Carlo (or GUM) result; its ``value`` is the mean simulated value.
    gum : UncertaintyResult or None
        The GUM linear result of the same simulation, when computed.
    validation : dict
        JCGM 101 §8 comparison of ``gum`` with ``result`` (empty without ``gum``).
    inputs : dict
        The input uncertainties used (for reports).
    """

    task: str
    quantity: str
    nominal: float
    result: UncertaintyResult
    gum: UncertaintyResult | None = None
    validation: dict[str, Any] = field(default_factory=dict)
    inputs: dict[str, Any] = field(default_factory=dict)

    def interval_about(self, measured: float) -> tuple[float, float]:
        """The coverage interval shifted to a measured value: ``measured + (interval - mean)``."""
        low, high = self.result.coverage_interval
        return measured + low - self.result.value, measured + high - self.result.value

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "task": self.task,
            "quantity": self.quantity,
            "nominal_mm": self.nominal,
            "result": self.result.to_dict(),
            "gum": None if self.gum is None else self.gum.to_dict(),
            "gum_validation": self.validation,
            "inputs": self.inputs,
        }


@record
class VirtualCMM:
    """The calibrated micro-CMM with what is known about its errors.

    Attributes
    ----------
    machine : RigidBodyMachine
        The calibrated model (tetrahedron from the calibration, columns).
    tip_radius : float
        Calibrated probe-tip radius (mm).
    calibration_covariance : ndarray, shape (28, 28) or None
        Covariance of :data:`~pcmm_geo.uncertainty.calibration.MODEL_PARAMETERS`
        (:meth:`CalibrationCovariance.model_covariance`); None: the calibration is exact.
    laser_sigma, encoder_sigma : float
        Standard uncertainties of one laser / encoder reading (mm).
    probing_sigma : float
        Probing scatter along the surface normal (mm).
    thermal : ThermalInputs
    """

    machine: Any
    tip_radius: float
    calibration_covariance: FloatArray | None = None
    laser_sigma: float = 0.0005
    encoder_sigma: float = 0.0002
    probing_sigma: float = 0.0
    thermal: ThermalInputs = field(default_factory=ThermalInputs)

    def __post_init__(self) -> None:
        for name in ("laser_sigma", "encoder_sigma"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InvalidInputError(name, "a positive standard uncertainty in mm", str(value))
        if not (math.isfinite(self.probing_sigma) and self.probing_sigma >= 0):
            raise InvalidInputError("probing_sigma", "a standard uncertainty >= 0 in mm", str(self.probing_sigma))
        if self.calibration_covariance is not None:
            cov = np.asarray(self.calibration_covariance, dtype=float)
            if cov.shape != (28, 28) or not np.all(np.isfinite(cov)):
                raise InvalidInputError("calibration_covariance", "a finite (28, 28) covariance", f"shape {cov.shape}")

    # ------------------------------------------------------------------------------- set-up
    @functools.cached_property
    def _calibration_root(self) -> FloatArray:
        """``L`` with ``L L^T`` = the calibration covariance (eigen-decomposition, PSD-safe), computed once."""
        cov = np.asarray(self.calibration_covariance, dtype=float)
        values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
        return vectors * np.sqrt(np.clip(values, 0.0, None))  # (28, 28): delta = root @ z

    def group_sizes(self, task: MeasurementTask) -> dict[str, int]:
        """Number of standard-normal inputs of each *active* group for ``task``."""
        points = len(task.contacts)
        sizes = {
            "calibration": 28 if self.calibration_covariance is not None else 0,
            "laser_noise": 3 * points,
            "encoder_noise": 3 * points,
            "probing": points if self.probing_sigma > 0 else 0,
            "thermal_machine": 7 if self.thermal.machine_active else 0,
            "thermal_workpiece": 2 if self.thermal.workpiece_active else 0,
        }
        return {name: size for name, size in sizes.items() if size}

    def nominal_readings(self, task: MeasurementTask) -> tuple[FloatArray, FloatArray]:
        """Lasers and heights ``(P, 3)`` of the calibrated model at the task's contacts."""
        tips = task.contacts + self.tip_radius * task.normals
        inverse = self.machine.inverse(tips)
        if not np.all(inverse.converged):
            raise ConvergenceError("inverse kinematics of the task contacts", int(inverse.iterations),
                                   "a contact is outside the working volume")
        return np.asarray(inverse.lasers), np.asarray(inverse.heights)

    # ------------------------------------------------------------------------------- model
    def evaluate_draws(self, task: MeasurementTask, draws: dict[str, FloatArray],
                       readings: tuple[FloatArray, FloatArray] | None = None) -> FloatArray:
        """Measured values ``(T,)`` for standard-normal draws ``{group: (T, n_group)}`` (missing = 0)."""
        nominal_l, nominal_h = readings if readings is not None else self.nominal_readings(task)
        trials = next(iter(draws.values())).shape[0] if draws else 1
        points = len(task.contacts)
        out = np.empty(trials)
        for start in range(0, trials, CHUNK):
            part = {name: d[start:start + CHUNK] for name, d in draws.items()}
            out[start:start + CHUNK] = self._evaluate_chunk(task, part, min(CHUNK, trials - start), points,
                                                            nominal_l, nominal_h)
        return out

    def _evaluate_chunk(self, task: MeasurementTask, draws: dict[str, FloatArray], trials: int, points: int,
                        nominal_l: FloatArray, nominal_h: FloatArray) -> FloatArray:
        geometry = BatchGeometry.repeat(self.machine, trials)
        radius = np.full(trials, float(self.tip_radius))
        if "calibration" in draws:
            delta = draws["calibration"] @ self._calibration_root.T  # (T, 28)
            per_arm = delta[:, :24].reshape(trials, 3, 8)
            geometry = replace(
                geometry,
                slider_points=geometry.slider_points + per_arm[:, :, 0:3],
                slider_directions=geometry.slider_directions + per_arm[:, :, 3:6],
                laser_scale=geometry.laser_scale + per_arm[:, :, 6],
                laser_offset=geometry.laser_offset + per_arm[:, :, 7],
                tip_center=geometry.tip_center + delta[:, 24:27],
            )
            radius = radius + delta[:, 27]
        if "thermal_machine" in draws:
            geometry = self._expand(geometry, draws["thermal_machine"])
        lasers = np.broadcast_to(nominal_l, (trials, points, 3))
        heights = np.broadcast_to(nominal_h, (trials, points, 3))
        if "laser_noise" in draws:
            lasers = lasers + self.laser_sigma * draws["laser_noise"].reshape(trials, points, 3)
        if "encoder_noise" in draws:
            heights = heights + self.encoder_sigma * draws["encoder_noise"].reshape(trials, points, 3)
        solution = forward_batch(
            self.machine, geometry, np.ascontiguousarray(lasers), np.ascontiguousarray(heights),
            laser_sigma=self.laser_sigma, height_sigma=self.encoder_sigma,
            nominal_lasers=nominal_l, nominal_heights=nominal_h,
        )
        if not solution.converged.all():
            raise ConvergenceError("virtual CMM kinematics", solution.iterations,
                                   f"{int((~solution.converged).sum())} pose solutions did not converge")
        measured = solution.tip - radius[:, None, None] * task.normals
        if "probing" in draws:
            measured = measured + self.probing_sigma * draws["probing"][..., None] * task.normals
        values = task.evaluate(measured)
        if "thermal_workpiece" in draws:
            values = values * self._workpiece_factor(draws["thermal_workpiece"])
        return values

    def _expand(self, geometry: BatchGeometry, z: FloatArray) -> BatchGeometry:
        th = self.thermal
        common = th.alpha_machine_u * (th.machine_temperature - REFERENCE_TEMPERATURE) * z[:, 6:7]
        arm = th.alpha_machine * th.arm_temperature_u * z[:, 0:3] + common  # (T, 3) strain
        column = th.alpha_machine * th.column_temperature_u * z[:, 3:6] + common
        tip = geometry.tip_center[:, None, :]
        grow = 1.0 + arm
        return replace(
            geometry,
            slider_points=tip + grow[..., None] * (geometry.slider_points - tip),
            laser_scale=geometry.laser_scale * grow,
            laser_offset=geometry.laser_offset * grow,
            encoder_scale=geometry.encoder_scale * (1.0 + column),
        )

    def _workpiece_factor(self, z: FloatArray) -> FloatArray:
        th = self.thermal
        stated = 1.0 + th.alpha_workpiece * (th.workpiece_temperature - REFERENCE_TEMPERATURE)
        alpha = th.alpha_workpiece + th.alpha_workpiece_u * z[:, 1]
        temperature = th.workpiece_temperature + th.workpiece_temperature_u * z[:, 0]
        return (1.0 + alpha * (temperature - REFERENCE_TEMPERATURE)) / stated

    def simulation(self, task: MeasurementTask, groups: tuple[str, ...] | None = None
                   ) -> Callable[[np.random.Generator, int], FloatArray]:
        """``simulate(rng, size) -> (size,)`` with the given groups varied (default: all active)."""
        sizes = self.group_sizes(task)
        active = {name: n for name, n in sizes.items() if groups is None or name in groups}
        readings = self.nominal_readings(task)

        def simulate(rng: np.random.Generator, size: int) -> FloatArray:
            draws = {name: rng.standard_normal((size, n)) for name, n in active.items()}
            if not draws:
                return np.full(size, float(self.evaluate_draws(task, {}, readings)[0]))
            return self.evaluate_draws(task, draws, readings)

        return simulate

    # ------------------------------------------------------------------------------- evaluations
    def gum(self, task: MeasurementTask, *, step: float = 0.1, probability: float = 0.95) -> UncertaintyResult:
        """GUM linear uncertainty of the task: central differences in every standard-normal input.

        The budget lists the groups, ``u_g(y) = sqrt(sum_{i in g} c_i^2)``.
        """
        from pcmm_geo.uncertainty.gum import coverage_factor

        sizes = self.group_sizes(task)
        total = sum(sizes.values())
        readings = self.nominal_readings(task)
        draws = {}
        column = 0
        for name, n in sizes.items():
            block = np.zeros((2 * total + 1, n))
            block[1 + column:1 + column + n] = step * np.eye(n)
            block[1 + total + column:1 + total + column + n] = -step * np.eye(n)
            draws[name] = block
            column += n
        values = self.evaluate_draws(task, draws, readings)
        value = float(values[0])
        sensitivities = (values[1:1 + total] - values[1 + total:]) / (2.0 * step)
        parts: dict[str, float] = {}
        column = 0
        for name, n in sizes.items():
            parts[name] = float(np.sqrt(np.sum(sensitivities[column:column + n] ** 2)))
            column += n
        u = float(np.sqrt(np.sum(sensitivities**2)))
        k = coverage_factor(math.inf, probability)
        variance = u**2
        budget = tuple(
            BudgetEntry(name, contribution=c, share=c**2 / variance if variance > 0 else 0.0)
            for name, c in parts.items()
        )
        return UncertaintyResult(
            quantity=task.quantity, unit="mm", method="GUM linear", value=value, standard_uncertainty=u,
            coverage_probability=probability, coverage_interval=(value - k * u, value + k * u),
            interval_kind="symmetric", expanded_uncertainty=k * u, coverage_factor=k, budget=budget,
        )

    def evaluate(
        self,
        task: MeasurementTask,
        *,
        seed: int | np.random.Generator = 0,
        trials: int | None = None,
        budget: bool = True,
        with_gum: bool = True,
        keep_values: bool = False,
        progress: Callable[..., None] | None = None,
        **monte_carlo_options: Any,
    ) -> TaskUncertainty:
        """Task-specific uncertainty by Monte Carlo (adaptive unless ``trials``), with budget and GUM check.

        Parameters
        ----------
        task : MeasurementTask
        seed : int or numpy.random.Generator
        trials : int, optional
            Fixed number of trials (default: adaptive, JCGM 101 §7.9).
        budget : bool
            Re-run with one group at a time for the budget.
        with_gum : bool
            Also compute the GUM linear result and compare (JCGM 101 §8).
        keep_values : bool
            Keep the simulated values (``result.values``) for a histogram.
        progress : callable, optional
            ``progress(done, total, text)``.
        **monte_carlo_options
            Passed to :func:`~pcmm_geo.uncertainty.montecarlo.adaptive_monte_carlo`.

        Returns
        -------
        TaskUncertainty

        See Also
        --------
        pcmm_geo.uncertainty.montecarlo.adaptive_monte_carlo : the adaptive Monte Carlo procedure
        pcmm_geo.uncertainty.montecarlo.validate_gum : the GUM check
        VirtualCMM.gum : the GUM linear evaluation of the same task


        Notes
        -----
        A simulation ("virtual CMM") evaluation of task-specific uncertainty in the sense of
        ISO/TS 15530-4 [1]_: every trial draws the inputs of each group (calibrated geometry,
        reading noise, probing, thermal state), measures the task on the simulated machine and
        evaluates it; the distribution of the results is propagated as JCGM 101 [2]_ describes.


        References
        ----------
        .. [1] ISO/TS 15530-4:2008, *Geometrical Product Specifications (GPS) -- Coordinate measuring machines
               (CMM): Technique for determining the uncertainty of measurement -- Part 4: Evaluating task-
               specific measurement uncertainty using simulation*.
        .. [2] JCGM 101:2008, *Evaluation of measurement data -- Supplement 1 to the GUM -- Propagation of
               distributions using a Monte Carlo method*.
        """
        from pcmm_geo.uncertainty.montecarlo import adaptive_monte_carlo, validate_gum

        groups = None
        if budget:
            groups = {name: self.simulation(task, (name,)) for name in self.group_sizes(task)}
        result = adaptive_monte_carlo(
            self.simulation(task), seed=seed, trials=trials, groups=groups, quantity=task.quantity, unit="mm",
            keep_values=keep_values, progress=progress,
            group_trials=monte_carlo_options.pop("group_trials", min(trials or 20_000, 20_000)),
            **monte_carlo_options,
        )
        gum = self.gum(task) if with_gum else None
        digits = int(monte_carlo_options.get("significant_digits", 2))
        validation = validate_gum(gum, result, significant_digits=digits) if gum is not None else {}
        th = self.thermal
        inputs = {
            "laser_sigma_mm": self.laser_sigma,
            "encoder_sigma_mm": self.encoder_sigma,
            "probing_sigma_mm": self.probing_sigma,
            "calibration": "covariance of the calibrated tetrahedron and tip radius"
            if self.calibration_covariance is not None else "taken as exact",
            "thermal": dict(th.__dict__),
        }
        return TaskUncertainty(task.name, task.quantity, task.nominal, result, gum, validation, inputs)
