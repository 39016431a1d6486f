"""End-to-end demonstration on generated data: calibrate a simulated micro-CMM, measure a gauge block.

The chain, every step with the library's own tools:

1. A "true" micro-CMM: the thesis geometry (:meth:`RigidBodyMachine.from_dpkm`) with
   manufacturing errors -- slider lines that miss the tip by a few millimetres (thesis
   fig 7.2) and laser scales that are not exactly 1.
2. An external CMM probes the tetrahedron's joint balls at three slider positions and
   the probe-tip ball (thesis 7.1), with probing noise.
3. :func:`~pcmm_geo.machine.calibrate_tetrahedron` recovers slider lines, laser
   scale/offset and tip centre (thesis ch. 7, without the seed's "lines meet at the tip"
   assumption, erratum 9).
4. The micro-CMM probes both measuring faces of a 100 mm gauge block: the true machine
   gives the readings (inverse kinematics) plus laser and encoder noise; the calibrated
   model and, for comparison, the uncalibrated nominal design turn the readings into tip
   centres (forward kinematics), which are compensated for the tip radius.
5. :func:`~pcmm_geo.artefacts.gauge_block.measure_gauge_block` evaluates the central length
   (ISO 3650 method) and the length error is reported.
6. The uncertainty of that length: the calibration's covariance
   (:func:`~pcmm_geo.uncertainty.calibration.calibration_covariance`, from the probing and
   laser noise) and the reading noise are propagated by the virtual micro-CMM
   (:class:`~pcmm_geo.uncertainty.virtual_cmm.VirtualCMM`, Monte Carlo, JCGM 101) to the
   expanded uncertainty ``U`` (95 % coverage).  The simulation's error sources are exactly
   these, so over many seeds the true error lies within ``+-U`` in about 95 % of runs
   (tests/uncertainty/test_demo_coverage.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._deprecation import renamed_parameters
from pcmm_geo._records import record

FloatArray = NDArray[np.float64]

ARMS = ("a", "b", "c")
#: Laser readings (mm) at which the external CMM probes the joint balls.
CALIBRATION_LASERS = np.array([[25.0, 30.0, 35.0], [95.0, 100.0, 90.0], [165.0, 170.0, 160.0]])


@dataclass(frozen=True)
class DemoSettings:
    """Settings of :func:`run_demo` (all lengths in mm)."""

    seed: int = 2026
    gauge_length: float = 100.0
    joint_ball_radius: float = 6.35
    tip_ball_radius: float = 1.0
    points_per_ball: int = 15
    cmm_probing_sigma: float = 0.0005
    laser_sigma: float = 0.0005
    encoder_sigma: float = 0.0002
    points_per_face: int = 5
    slider_offsets: tuple[tuple[float, float, float], ...] = (
        (0.0, 3.0, -1.0),
        (-2.5, 1.0, 0.5),
        (1.5, 2.0, 1.0),
    )
    laser_scales: tuple[float, float, float] = (1.002, 0.998, 1.001)
    #: Monte Carlo trials of the virtual CMM for the uncertainty (0: GUM linear instead)
    uncertainty_trials: int = 10_000
    #: also run the virtual CMM one input group at a time (the budget)
    uncertainty_budget: bool = True


@record
class DemoResult:
    """What :func:`run_demo` found; ``to_dict()`` is JSON-ready."""

    settings: DemoSettings
    true_slider_miss: dict[str, float]
    calibration: dict[str, Any]
    gauge_length: float
    measured_length_calibrated: float
    measured_length_nominal: float
    tip_error_rms_calibrated: float
    tip_error_rms_nominal: float
    face_form_calibrated: tuple[float, float]
    plots: list[str] = field(default_factory=list)
    #: task-specific uncertainty of the calibrated length (virtual CMM; not in ``to_dict`` except U, k, budget)
    length_uncertainty: Any = field(default=None, repr=False, compare=False)
    #: the full calibration result (not in ``to_dict``), for plots
    tetrahedron_calibration: Any = field(default=None, repr=False, compare=False)
    #: measured minus true tip centres per model, face by face, ``{model: [(N, 3), ...]}`` (mm; not in ``to_dict``)
    tip_errors: dict[str, list[FloatArray]] = field(default_factory=dict, repr=False, compare=False)

    @property
    def length_error_calibrated(self) -> float:
        """Measured minus true central length with the calibrated model (mm)."""
        return self.measured_length_calibrated - self.gauge_length

    @property
    def length_error_nominal(self) -> float:
        """Measured minus true central length with the nominal design model (mm)."""
        return self.measured_length_nominal - self.gauge_length

    @property
    def expanded_uncertainty_calibrated(self) -> float:
        """Expanded uncertainty (95 % coverage) of the calibrated central length (mm); NaN if not evaluated."""
        if self.length_uncertainty is None:
            return float("nan")
        return float(self.length_uncertainty.result.expanded_uncertainty)

    def _uncertainty_dict(self) -> dict[str, Any]:
        if self.length_uncertainty is None:
            return {"expanded_uncertainty_calibrated_mm": None}
        result = self.length_uncertainty.result
        low, high = self.length_uncertainty.interval_about(self.measured_length_calibrated)
        return {
            "expanded_uncertainty_calibrated_mm": result.expanded_uncertainty,
            "uncertainty_calibrated": {
                "standard_uncertainty_mm": result.standard_uncertainty,
                "coverage_factor": result.coverage_factor,
                "coverage_probability": result.coverage_probability,
                "coverage_interval_mm": [low, high],
                "method": result.method,
                "n_trials": result.n_trials,
                "budget_mm": {entry.name: entry.contribution for entry in result.budget},
            },
        }

    def to_dict(self) -> dict[str, Any]:
        return {
            "settings": self.settings.__dict__,
            "true_slider_miss_mm": self.true_slider_miss,
            "calibration": self.calibration,
            "gauge_length_mm": self.gauge_length,
            "measured_length_calibrated_mm": self.measured_length_calibrated,
            "measured_length_nominal_mm": self.measured_length_nominal,
            "length_error_calibrated_mm": self.length_error_calibrated,
            **self._uncertainty_dict(),
            "length_error_nominal_mm": self.length_error_nominal,
            "tip_error_rms_calibrated_mm": self.tip_error_rms_calibrated,
            "tip_error_rms_nominal_mm": self.tip_error_rms_nominal,
            "face_form_calibrated_mm": list(self.face_form_calibrated),
            "plots": self.plots,
        }


def true_machine(settings: DemoSettings) -> Any:
    """The simulated machine: the thesis design with skewed slider lines and laser scale errors."""
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine, SliderLine, Tetrahedron

    nominal = RigidBodyMachine.from_dpkm()
    sliders = {}
    for arm, offset, scale in zip(ARMS, settings.slider_offsets, settings.laser_scales, strict=True):
        slider = nominal.tetrahedron.sliders[arm]
        shift = np.asarray(offset, dtype=float)
        shift = shift - (shift @ slider.direction) * slider.direction  # sideways: the line misses the tip
        sliders[arm] = SliderLine(
            point=slider.point + shift,
            direction=slider.direction,
            laser_scale=scale,
            laser_offset=slider.laser_offset,
        )
    tetrahedron = Tetrahedron(sliders=sliders, tip_center=nominal.tetrahedron.tip_center)
    return RigidBodyMachine(
        tetrahedron=tetrahedron,
        columns=nominal.columns,
        reference_lasers=nominal.reference_lasers,
        reference_heights=nominal.reference_heights,
    )


@renamed_parameters(centre="center")
def ball_probings(center: FloatArray, radius: float, count: int, sigma: float, rng: np.random.Generator) -> FloatArray:
    """Points an external CMM takes on a ball: a spiral over its upper 3/4, plus Gaussian noise."""
    golden_angle = np.pi * (3.0 - np.sqrt(5.0))
    index = np.arange(count)
    height = 1.0 - 1.5 * (index + 0.5) / count
    ring = np.sqrt(1.0 - height**2)
    unit = np.column_stack([ring * np.cos(golden_angle * index), ring * np.sin(golden_angle * index), height])
    return center + radius * unit + rng.normal(0.0, sigma, (count, 3))


def simulate_probings(machine: Any, settings: DemoSettings, rng: np.random.Generator) -> dict[str, Any]:
    """External-CMM probings of the joint balls at :data:`CALIBRATION_LASERS` and of the tip ball."""
    probings: dict[str, Any] = {
        "tip": ball_probings(
            machine.tetrahedron.tip_center,
            settings.tip_ball_radius,
            settings.points_per_ball,
            settings.cmm_probing_sigma,
            rng,
        )
    }
    for k, arm in enumerate(ARMS):
        slider = machine.tetrahedron.sliders[arm]
        probings[f"joint_{arm}"] = {
            position + 1: ball_probings(
                slider.joint(lasers[k]),
                settings.joint_ball_radius,
                settings.points_per_ball,
                settings.cmm_probing_sigma,
                rng,
            )
            for position, lasers in enumerate(CALIBRATION_LASERS)
        }
    return probings


@renamed_parameters(centre="center")
def gauge_block_contacts(center: FloatArray, settings: DemoSettings) -> dict[str, tuple[FloatArray, FloatArray]]:
    """Surface points and outward normals on the two measuring faces of a block along x."""
    half = settings.gauge_length / 2.0
    # a 9 mm x 35 mm measuring face: points on a small cross around the face centre
    offsets = np.array([[0.0, 0.0], [0.0, 12.0], [0.0, -12.0], [3.0, 0.0], [-3.0, 0.0], [2.0, 8.0], [-2.0, -8.0]])
    offsets = offsets[: settings.points_per_face]
    faces = {}
    for name, sign in (("face_1", -1.0), ("face_2", 1.0)):
        normal = np.array([sign, 0.0, 0.0])
        surface = center + np.column_stack(
            [np.full(len(offsets), sign * half), offsets[:, 1], offsets[:, 0]]
        )
        faces[name] = (surface, np.tile(normal, (len(surface), 1)))
    return faces


def run_demo(
    settings: DemoSettings | None = None,
    *,
    out_dir: str | Path | None = None,
    progress: Callable[[int, int, str], None] | None = None,
) -> DemoResult:
    """Run the end-to-end demonstration (see the module docstring).

    Parameters
    ----------
    settings : DemoSettings, optional
    out_dir : path, optional
        Folder for the plots (created; must not contain the plot files already).
    progress : callable, optional
        ``progress(steps_done, steps_total, next_step_text)`` is called before each step
        and ``progress(steps_total, steps_total, "done")`` at the end.

    Returns
    -------
    DemoResult

    Raises
    ------
    OutputExistsError
        A plot file already exists in ``out_dir``.

    Examples
    --------
    >>> result = run_demo(DemoSettings(seed=1))
    >>> bool(abs(result.length_error_calibrated) < 0.005 < abs(result.length_error_nominal))
    True
    """
    from pcmm_geo.artefacts.gauge_block import measure_gauge_block
    from pcmm_geo.machine.calibration import calibrate_tetrahedron
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine

    settings = settings or DemoSettings()
    rng = np.random.default_rng(settings.seed)
    steps_total = 6 if out_dir is not None else 5
    steps_done = [0]

    def say(text: str) -> None:
        if progress is not None:
            progress(steps_done[0], steps_total, text)
        steps_done[0] += 1

    say("building the simulated micro-CMM")
    machine = true_machine(settings)
    nominal = RigidBodyMachine.from_dpkm()
    miss = {
        arm: float(
            np.linalg.norm(np.cross(machine.tetrahedron.tip_center - s.point, s.direction))
        )
        for arm, s in machine.tetrahedron.sliders.items()
    }

    say("external CMM probing the tetrahedron and calibrating (thesis ch. 7)")
    probings = simulate_probings(machine, settings, rng)
    calibration_lasers = CALIBRATION_LASERS + rng.normal(0.0, settings.laser_sigma, CALIBRATION_LASERS.shape)
    calibration = calibrate_tetrahedron(probings, calibration_lasers)
    calibrated = RigidBodyMachine(
        tetrahedron=calibration.tetrahedron,
        columns=machine.columns,
        reference_lasers=machine.reference_lasers,
        reference_heights=machine.reference_heights,
    )

    say("micro-CMM probing the gauge block")
    reference_tip = machine.forward(heights=machine.reference_heights, lasers_hint=machine.reference_lasers).tip
    faces = gauge_block_contacts(np.asarray(reference_tip), settings)
    tip_radius = float(calibration.tip.radius)
    measured: dict[str, dict[str, FloatArray]] = {"calibrated": {}, "nominal": {}}
    tip_errors: dict[str, list[FloatArray]] = {"calibrated": [], "nominal": []}
    for name, (surface, normal) in faces.items():
        true_tips = surface + settings.tip_ball_radius * normal
        readings = machine.inverse(true_tips)
        lasers = readings.lasers + rng.normal(0.0, settings.laser_sigma, readings.lasers.shape)
        heights = readings.heights + rng.normal(0.0, settings.encoder_sigma, readings.heights.shape)
        for label, model in (("calibrated", calibrated), ("nominal", nominal)):
            # the nominal (thesis) geometry does not close the loops of the true machine's readings by mm:
            # that is the point of the comparison, so only the calibrated model is held to the limits
            solution = model.forward(
                lasers, heights, laser_sigma=settings.laser_sigma, height_sigma=settings.encoder_sigma,
                check_limits=label == "calibrated",
            )
            tip_errors[label].append(solution.tip - true_tips)
            # probe compensation along the approach direction (the face normal)
            radius = tip_radius if label == "calibrated" else settings.tip_ball_radius
            measured[label][name] = solution.tip - radius * normal

    say("evaluating the gauge block (ISO 3650 method)")
    result_cal = measure_gauge_block(measured["calibrated"])
    result_nom = measure_gauge_block(measured["nominal"])
    summary = {
        "dead_distance_mm": dict(calibration.dead_distance),
        "beta_deg": calibration.beta_deg,
        "skew_distance_mm": dict(calibration.skew_distances),
        "tip_centre_mm": np.asarray(calibration.tip_center).tolist(),
        "tip_radius_mm": tip_radius,
        "laser_scale": {arm: float(line.laser_scale) for arm, line in calibration.slider_lines.items()},
        "slider_line_error_mm": {
            arm: float(
                np.linalg.norm(
                    np.cross(calibration.slider_lines[arm].point - machine.tetrahedron.sliders[arm].point,
                             machine.tetrahedron.sliders[arm].direction)
                )
            )
            for arm in ARMS
        },
    }
    say("uncertainty of the calibrated length (virtual micro-CMM, JCGM 101)")
    uncertainty = _length_uncertainty(settings, probings, calibration_lasers, calibrated, tip_radius,
                                      np.asarray(reference_tip), rng)
    plots: list[str] = []
    if out_dir is not None:
        say("writing plots")
        plots = _write_plots(Path(out_dir), calibration, tip_errors)
    if progress is not None:
        progress(steps_total, steps_total, "done")

    def rms(errors: list[FloatArray]) -> float:
        stacked = np.concatenate(errors)
        return float(np.sqrt(np.mean(np.sum(stacked**2, axis=1))))

    return DemoResult(
        settings=settings,
        true_slider_miss=miss,
        calibration=summary,
        gauge_length=settings.gauge_length,
        measured_length_calibrated=float(result_cal.central_length),
        measured_length_nominal=float(result_nom.central_length),
        tip_error_rms_calibrated=rms(tip_errors["calibrated"]),
        tip_error_rms_nominal=rms(tip_errors["nominal"]),
        face_form_calibrated=tuple(float(v) for v in result_cal.face_form),  # type: ignore[arg-type]
        plots=plots,
        length_uncertainty=uncertainty,
        tetrahedron_calibration=calibration,
        tip_errors=tip_errors,
    )


def demo_calibrated_machine(settings: DemoSettings | None = None) -> tuple[Any, float, Any, FloatArray]:
    """The demo's calibrated micro-CMM with its calibration covariance (for ``pcmm uncertainty``).

    Returns
    -------
    machine : RigidBodyMachine
        Calibrated tetrahedron on the true (nominal) columns.
    tip_radius : float
        Calibrated tip radius (mm).
    covariance : CalibrationCovariance
        From the demo's probing and laser noise.
    reference_tip : ndarray, shape (3,)
        Tip centre in the middle of the working volume (mm).
    """
    from pcmm_geo.machine.calibration import calibrate_tetrahedron
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    from pcmm_geo.uncertainty.calibration import calibration_covariance

    settings = settings or DemoSettings()
    rng = np.random.default_rng(settings.seed)
    machine = true_machine(settings)
    probings = simulate_probings(machine, settings, rng)
    lasers = CALIBRATION_LASERS + rng.normal(0.0, settings.laser_sigma, CALIBRATION_LASERS.shape)
    calibration = calibrate_tetrahedron(probings, lasers)
    covariance = calibration_covariance(
        probings, lasers, probing_sigma=settings.cmm_probing_sigma, laser_sigma=settings.laser_sigma
    )
    calibrated = RigidBodyMachine(calibration.tetrahedron, machine.columns, machine.reference_lasers,
                                  machine.reference_heights)
    reference_tip = machine.forward(heights=machine.reference_heights, lasers_hint=machine.reference_lasers).tip
    return calibrated, float(calibration.tip.radius), covariance, np.asarray(reference_tip)


def _length_uncertainty(
    settings: DemoSettings, probings: Any, lasers: FloatArray, calibrated: Any, tip_radius: float,
    center: FloatArray, rng: np.random.Generator,
) -> Any:
    """Virtual-CMM uncertainty of the gauge-block length with the demo's error sources."""
    from pcmm_geo.uncertainty.calibration import calibration_covariance
    from pcmm_geo.uncertainty.tasks import gauge_block_task
    from pcmm_geo.uncertainty.virtual_cmm import TaskUncertainty, VirtualCMM

    covariance = calibration_covariance(
        probings, lasers, probing_sigma=settings.cmm_probing_sigma, laser_sigma=settings.laser_sigma
    )
    vcmm = VirtualCMM(
        calibrated, tip_radius, covariance.model_covariance()[1],
        laser_sigma=settings.laser_sigma, encoder_sigma=settings.encoder_sigma,
    )
    task = gauge_block_task(settings.gauge_length, center, points_per_face=settings.points_per_face)
    if settings.uncertainty_trials <= 0:
        gum = vcmm.gum(task)
        return TaskUncertainty(task.name, task.quantity, task.nominal, gum, gum)
    return vcmm.evaluate(
        task, seed=rng, trials=settings.uncertainty_trials, budget=settings.uncertainty_budget,
        with_gum=settings.uncertainty_budget, group_trials=max(2000, settings.uncertainty_trials // 2),
    )


def _write_plots(folder: Path, calibration: Any, tip_errors: dict[str, list[FloatArray]]) -> list[str]:
    """Slider lines, joint centres and tip (thesis fig 7.2) and the tip errors per contact."""
    from pcmm_geo.errors import OutputExistsError
    from pcmm_geo.plots.demo import plot_tip_errors
    from pcmm_geo.plots.machine.calibration import plot_calibration

    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / "calibration_3d.png", folder / "gauge_block_tip_errors.png"]
    for path in paths:
        if path.exists():
            raise OutputExistsError(str(path))
    plot_calibration(calibration, paths[0])
    plot_tip_errors(tip_errors, paths[1])
    return [str(p) for p in paths]
