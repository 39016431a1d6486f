"""Rigid-body model of the parallel-mechanism micro-CMM (general form of the seed's DPKM).

Geometry (DESIGN.md "Machine model"):

* the **tetrahedron** is one rigid body.  In its own frame arm ``i`` carries a slider
  that moves on a straight line ``q_i + s w_i`` (``w_i`` unit, pointing from the tip side
  towards the spherical joint); the slider position ``s`` follows from the laser reading
  ``s = laser_scale * laser + laser_offset``.  The probe-tip centre is the point ``p``.
* in the **machine frame** the spherical joint (pivot) of arm ``i`` rides on column
  ``i``: ``c_i + z v_i`` (``v_i`` unit, upwards) with ``z = encoder_scale * height``
  (seed eqs 2.19-2.20 are the special case ``c_i = (g_i, m_i, 0)``, ``v_i ~ (h_i, n_i, 1)``).
* the pose ``T = (R, t)`` of the tetrahedron closes the three loops
  ``R (q_i + s_i w_i) + t = c_i + z_i v_i``; the probe-tip centre is ``R p + t``.

The seed DPKM (eqs 2.3-2.21) is the special case where the three slider lines meet at
the tip; :meth:`RigidBodyMachine.from_dpkm` builds that geometry and both agree there.
Nothing here assumes the lines meet, which removes erratum 9 of DESIGN.md.

Arms are ordered ``a, b, c`` (:data:`ARMS`), clockwise seen from above (thesis 2.6.4); mm and rad throughout.

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
>>> machine = RigidBodyMachine.from_dpkm()
>>> inv = machine.inverse([0.0, 0.0, 90.0])
>>> fwd = machine.forward(lasers=inv.lasers, heights=inv.heights)
>>> bool(np.allclose(fwd.tip, [0.0, 0.0, 90.0], atol=1e-9))
True
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.kinematics import _pose_solver as solver
from pcmm_geo.machine.kinematics.dpkm import START_OF_RANGE, seed_parts
from pcmm_geo.machine.kinematics.limits import MachineLimits, check_inverse, check_reach, closure_norms
from pcmm_geo.machine.kinematics.model_parts import (
    ARMS,
    ColumnLine,
    ForwardSolution,
    InverseSolution,
    SliderLine,
    Tetrahedron,
    as_readings,
    as_vector3,
    check_arm_keys,
)

__all__ = [
    "ARMS",
    "MODEL_SCHEMA",
    "ColumnLine",
    "ForwardSolution",
    "InverseSolution",
    "MachineLimits",
    "RigidBodyMachine",
    "SliderLine",
    "Tetrahedron",
    "as_readings",
    "as_vector3",
    "seed_machine",
]

FloatArray = NDArray[np.float64]

#: schema identifier written by :meth:`RigidBodyMachine.to_dict`
MODEL_SCHEMA = "pcmm_geo.machine.rigid_body/1"


@record
class RigidBodyMachine:
    """The rigid-body machine: tetrahedron plus column lines.

    Attributes
    ----------
    tetrahedron : Tetrahedron
    columns : mapping str -> ColumnLine
        Keys ``"a", "b", "c"``.
    reference_lasers, reference_heights : ndarray, shape (3,)
        A configuration near the middle of the working range used as starting values
        and as the hint for readings the data cannot determine.
    limits : MachineLimits
        Column travel, laser measuring range and closure tolerance
        (:mod:`~pcmm_geo.machine.kinematics.limits`).  Default (``None`` given):
        :meth:`MachineLimits.seed` -- the seed's height frame: 450 mm travel from 277.22 to
        727.22 mm (park position at 400 mm), lasers 0-200 mm, closure tolerance 0.25 mm.
    """

    tetrahedron: Tetrahedron
    columns: Mapping[str, ColumnLine]
    reference_lasers: FloatArray = field(default_factory=lambda: np.full(3, 100.0))
    reference_heights: FloatArray = field(default_factory=lambda: np.zeros(3))
    limits: MachineLimits = None  # type: ignore[assignment]  # None -> MachineLimits.seed()

    def __post_init__(self) -> None:
        check_arm_keys(self.columns, "columns")
        object.__setattr__(self, "columns", {arm: self.columns[arm] for arm in ARMS})
        object.__setattr__(self, "reference_lasers", as_vector3(self.reference_lasers, "reference_lasers"))
        object.__setattr__(self, "reference_heights", as_vector3(self.reference_heights, "reference_heights"))
        if self.limits is None:
            object.__setattr__(self, "limits", MachineLimits.seed())
        elif not isinstance(self.limits, MachineLimits):
            raise InvalidInputError("limits", "a MachineLimits or None", type(self.limits).__name__)

    # ------------------------------------------------------------------ geometry
    @property
    def geometry(self) -> solver.Geometry:
        """Stacked arrays of the geometry (internal use by the solvers)."""
        sliders = [self.tetrahedron.sliders[arm] for arm in ARMS]
        columns = [self.columns[arm] for arm in ARMS]
        return solver.Geometry(
            slider_points=np.array([s.point for s in sliders]),
            slider_directions=np.array([s.direction for s in sliders]),
            laser_scale=np.array([s.laser_scale for s in sliders]),
            laser_offset=np.array([s.laser_offset for s in sliders]),
            tip_center=self.tetrahedron.tip_center,
            column_points=np.array([c.point for c in columns]),
            column_directions=np.array([c.direction for c in columns]),
            encoder_scale=np.array([c.encoder_scale for c in columns]),
        )

    def joints(self, lasers: ArrayLike) -> FloatArray:
        """Joint centres ``(..., 3, 3)`` in the tetrahedron frame for lasers ``(..., 3)``."""
        readings = as_readings(lasers, "lasers")
        return solver.joints_in_tetrahedron(self.geometry, readings)

    def pivots(self, heights: ArrayLike) -> FloatArray:
        """Pivot centres ``(..., 3, 3)`` in the machine frame for height readings ``(..., 3)``."""
        readings = as_readings(heights, "heights")
        return solver.pivots_in_machine(self.geometry, readings)

    # ------------------------------------------------------------------ kinematics
    def forward(
        self,
        lasers: ArrayLike | None = None,
        heights: ArrayLike | None = None,
        *,
        laser_sigma: float = 1e-3,
        height_sigma: float = 1e-3,
        heights_hint: ArrayLike | None = None,
        lasers_hint: ArrayLike | None = None,
        check_limits: bool = True,
    ) -> ForwardSolution:
        """Forward kinematics: readings -> pose and probe-tip centre.

        Solves ``R (q_i + s_i w_i) + t = c_i + z_i v_i`` (i = a, b, c) exactly for the pose
        and the readings, minimising ``sum ((reading - measured) / sigma)^2`` over the
        measured readings (maximum likelihood for independent Gaussian reading errors).
        With only one kind of reading the system is square and solved exactly.

        Parameters
        ----------
        lasers, heights : array_like, shape (..., 3), optional
            Laser and height (encoder) readings in arm order a, b, c.  At least one.
        laser_sigma, height_sigma : float
            Standard uncertainties of the readings (reading units), used as weights when
            both are given.
        heights_hint, lasers_hint : array_like, shape (..., 3) or (3,), optional
            Starting values for readings not measured (default: the reference readings).
            With parallel columns and lasers only, the common height of the pivots is not
            observable; the solution then takes the heights nearest the hint.
        check_limits : bool
            Check the readings against :attr:`limits` (default).  ``False`` (analyses beyond
            the machine: simulators, finite differences) raises nothing for range or
            consistency; ``converged`` and ``residuals`` stay truthful.

        Returns
        -------
        ForwardSolution
            ``converged`` only where the loops close to 1e-6 mm with the solved readings
            (with one kind of reading also with the measured ones).

        Raises
        ------
        InvalidInputError
            No readings, mismatched shapes, non-finite values, non-positive sigma.
        OutOfRangeError
            A measured reading outside the column travel or laser range, or one the solve
            implies (heights whose pose needs a laser beyond 200 mm).  ``quantity`` names
            the index, e.g. ``"lasers[4, 1] (laser b measuring range)"``; fields ``index``.
        InconsistentMeasurementError
            The largest loop-closure residual with the measured readings exceeds
            ``limits.closure_tolerance`` (lasers and heights disagree, or no pose realises
            the lasers, e.g. 200, 200, 200).  Fields ``residual``, ``tolerance``, ``index``.

        See Also
        --------
        pcmm_geo.machine.kinematics.dpkm.dpkm_probe : the thesis' DPKM (slider lines that meet at the tip)
        RigidBodyMachine.inverse : the readings of a tip position

        Notes
        -----
        *What the readings determine.*  The machine has three degrees of freedom (the
        motors).  Heights alone determine the pose (square system).  Lasers alone see only
        two of them when the columns are parallel (a vertical slide of the tetrahedron
        changes no laser) and none at first order when the three pivots are level (pivot
        distances change with the square of a height difference); they also leave a
        two-fold branch (tetrahedron tilted one way or its mirror).  ``heights_hint`` picks
        the branch and the datum; ``converged`` is False where the lasers are blind.

        *Noise* grows linearly, as the Jacobian predicts (:mod:`pcmm_geo.machine.analysis.sensitivity`):
        seed geometry, 100 mm cube, about ``1.5 sigma`` RMS tip error for height noise, laser
        noise amplified about 4x (median, lasers only) and without bound near level pivots.

        The model generalises the thesis' DPKM [1]_: there the three slider lines meet at the tip.

        References
        ----------
        .. [1] The thesis (see :doc:`/errata`): section 2.6.4, the DPKM; chapter 7, the slider lines.

        Examples
        --------
        >>> machine = RigidBodyMachine.from_dpkm()
        >>> target = [[10.0, -20.0, 110.0], [-30.0, 25.0, 70.0]]
        >>> inv = machine.inverse(target)
        >>> sol = machine.forward(lasers=inv.lasers, heights=inv.heights)
        >>> bool(np.allclose(sol.tip, target, atol=1e-9)), sol.residuals.shape
        (True, (2, 9))
        """
        if lasers is None and heights is None:
            raise InvalidInputError("forward", "lasers and/or heights", "neither")
        for name, sigma in (("laser_sigma", laser_sigma), ("height_sigma", height_sigma)):
            if not (np.isfinite(sigma) and sigma > 0):
                raise InvalidInputError(name, "a positive finite number", str(sigma))
        laser_arr = None if lasers is None else as_readings(lasers, "lasers")
        height_arr = None if heights is None else as_readings(heights, "heights")
        if laser_arr is not None and height_arr is not None and laser_arr.shape != height_arr.shape:
            raise InvalidInputError("heights", f"the shape of lasers {laser_arr.shape}", f"shape {height_arr.shape}")
        if check_limits:
            self.limits.check_readings(laser_arr, height_arr)
        shape = (laser_arr if laser_arr is not None else height_arr).shape  # type: ignore[union-attr]
        lead = shape[:-1]
        count = int(np.prod(lead, dtype=int))
        ref_l = np.broadcast_to(
            self.reference_lasers if lasers_hint is None else as_readings(lasers_hint, "lasers_hint"), shape
        ).reshape(count, 3)
        ref_h = np.broadcast_to(
            self.reference_heights if heights_hint is None else as_readings(heights_hint, "heights_hint"), shape
        ).reshape(count, 3)
        meas_l = ref_l if laser_arr is None else laser_arr.reshape(count, 3)
        meas_h = ref_h if height_arr is None else height_arr.reshape(count, 3)
        weak = 1.0 / solver.PRIOR_RATIO
        w_l = np.full((count, 3), 1.0 / laser_sigma if laser_arr is not None else weak / laser_sigma)
        w_h = np.full((count, 3), 1.0 / height_sigma if height_arr is not None else weak / height_sigma)
        geometry = self.geometry
        start = solver.kabsch_start(geometry, meas_l, meas_h)
        state = solver.solve_pose(
            geometry, start, laser_weight=w_l, height_weight=w_h, laser_target=meas_l, height_target=meas_h
        )
        if laser_arr is None or height_arr is None:  # second stage: drop the prior, keep what is unobservable
            first_iterations = state.iterations
            w_l = w_l if laser_arr is not None else np.zeros_like(w_l)
            w_h = w_h if height_arr is not None else np.zeros_like(w_h)
            state = solver.solve_pose(
                geometry, state, laser_weight=w_l, height_weight=w_h, laser_target=meas_l, height_target=meas_h,
                rcond=solver.UNOBSERVABLE,
            )
            state = dataclasses.replace(state, iterations=state.iterations + first_iterations)
        reported = solver.PoseState(
            state.rotation,
            state.translation,
            state.lasers if laser_arr is None else meas_l,
            state.heights if height_arr is None else meas_h,
            state.converged,
            state.iterations,
        )
        residuals = solver.closure(geometry, reported)
        closed = solver.open_equations(geometry, state) <= solver.SOLVED_TOLERANCE
        if laser_arr is None or height_arr is None:  # square system: the measured readings must be met
            closed &= closure_norms(residuals) <= solver.SOLVED_TOLERANCE
        if check_limits:
            implied_lasers = state.lasers.reshape(*lead, 3) if laser_arr is None else None
            implied_heights = state.heights.reshape(*lead, 3) if height_arr is None else None
            self.limits.check_solution(residuals.reshape(*lead, 9), implied_lasers, implied_heights)
        tip = np.einsum("kij,j->ki", state.rotation, geometry.tip_center) + state.translation
        return ForwardSolution(
            tip=tip.reshape(*lead, 3),
            rotation=state.rotation.reshape(*lead, 3, 3),
            translation=state.translation.reshape(*lead, 3),
            lasers=state.lasers.reshape(*lead, 3),
            heights=state.heights.reshape(*lead, 3),
            residuals=residuals.reshape(*lead, 9),
            converged=(state.converged & closed).reshape(lead),
            iterations=state.iterations,
        )

    def inverse(
        self, tip: ArrayLike, *, heights_hint: ArrayLike | None = None, check_limits: bool = True
    ) -> InverseSolution:
        """Inverse kinematics: probe-tip centre -> heights, lasers and pose.

        Solves the nine loop-closure equations plus ``R p + t = tip`` (12 equations,
        12 unknowns) by Newton's method from the reference pose moved to the target.

        Parameters
        ----------
        tip : array_like, shape (..., 3)
            Target probe-tip centres in the machine frame (mm).
        heights_hint : array_like, shape (..., 3) or (3,), optional
            Starting height readings (default: the reference heights).
        check_limits : bool
            Refuse targets the machine cannot reach (default).  ``False`` returns the
            solution of the equations whatever the readings; ``converged`` stays truthful.

        Returns
        -------
        InverseSolution
            ``converged`` is True only where the loop and the tip equations close to 1e-6 mm.

        Raises
        ------
        InvalidInputError
            Wrong shape or non-finite target.
        OutOfRangeError
            The target lies beyond an arm's span from its column's travel ("distance of
            tip[i] from column a", :func:`~pcmm_geo.machine.kinematics.limits.check_reach`)
            or needs readings outside the limits ("heights[2, 0] (column a travel, needed
            for the tip)").  Fields ``index``, ``value``, ``low``, ``high``.
        NoRealSolutionError
            The Newton iteration found no pose for the target; field ``index``.

        Examples
        --------
        >>> machine = RigidBodyMachine.from_dpkm()
        >>> inv = machine.inverse([5.0, 5.0, 100.0])
        >>> inv.heights.shape, bool(inv.converged)
        ((3,), True)
        """
        target = as_readings(tip, "tip")
        lead = target.shape[:-1]
        count = int(np.prod(lead, dtype=int))
        flat_target = target.reshape(count, 3)
        geometry = self.geometry
        if check_limits:
            check_reach(geometry, self.limits, target)
        ref = self.forward(lasers=self.reference_lasers, heights_hint=self.reference_heights, check_limits=False)
        hint = np.broadcast_to(
            ref.heights if heights_hint is None else as_readings(heights_hint, "heights_hint"), (*lead, 3)
        ).reshape(count, 3)
        rotation = np.broadcast_to(ref.rotation, (count, 3, 3)).copy()
        translation = flat_target - rotation @ geometry.tip_center
        # readings nearest to the shifted reference pose: joint line vs column line closest points
        lasers, heights = solver.closest_readings(geometry, rotation, translation, hint)
        start = solver.PoseState(rotation, translation, lasers, heights, np.zeros(count, bool), 0)
        zeros = np.zeros((count, 3))
        state = solver.solve_pose(
            geometry, start, laser_weight=zeros, height_weight=zeros, laser_target=zeros, height_target=zeros,
            tip_target=flat_target,
        )
        error = solver.open_equations(geometry, state, flat_target)
        converged = state.converged & (error <= solver.SOLVED_TOLERANCE)
        if check_limits:
            check_inverse(self.limits, target, converged.reshape(lead), error.reshape(lead), state, lead)
        return InverseSolution(
            heights=state.heights.reshape(*lead, 3),
            lasers=state.lasers.reshape(*lead, 3),
            rotation=state.rotation.reshape(*lead, 3, 3),
            translation=state.translation.reshape(*lead, 3),
            converged=converged.reshape(lead),
            iterations=state.iterations,
        )

    # ------------------------------------------------------------------ construction / serialisation
    @classmethod
    def from_dpkm(cls, **seed_parameters: Any) -> RigidBodyMachine:
        """The seed geometry: slider lines meeting at the tip (see :func:`seed_machine`).

        Keyword arguments are passed to :func:`seed_machine`
        (``dead_distance``, ``beta_deg``, ``column_points``, ``column_slopes``,
        ``start_of_range``); all default to the thesis' Table 3.1 / Appendix D values.

        Examples
        --------
        >>> m = RigidBodyMachine.from_dpkm()
        >>> round(float(m.tetrahedron.sliders["a"].laser_offset), 2)
        354.02
        """
        return seed_machine(**seed_parameters)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary with ``schema`` = :data:`MODEL_SCHEMA`."""
        return {
            "schema": MODEL_SCHEMA,
            "units": "mm",
            "tetrahedron": {
                "tip_centre": self.tetrahedron.tip_center.tolist(),
                "sliders": {
                    arm: {
                        "point": s.point.tolist(),
                        "direction": s.direction.tolist(),
                        "laser_scale": float(s.laser_scale),
                        "laser_offset": float(s.laser_offset),
                    }
                    for arm, s in self.tetrahedron.sliders.items()
                },
            },
            "columns": {
                arm: {"point": c.point.tolist(), "direction": c.direction.tolist(), "encoder_scale": c.encoder_scale}
                for arm, c in self.columns.items()
            },
            "reference_lasers": self.reference_lasers.tolist(),
            "reference_heights": self.reference_heights.tolist(),
            "limits": self.limits.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RigidBodyMachine:
        """Rebuild a machine written by :meth:`to_dict`.

        A document without ``"limits"`` (written before limits existed) gets the default
        :meth:`MachineLimits.seed` (the seed's height frame).

        Raises
        ------
        InvalidInputError
            Missing keys or a different schema.
        """
        if not isinstance(data, Mapping) or data.get("schema") != MODEL_SCHEMA:
            got = data.get("schema") if isinstance(data, Mapping) else type(data).__name__
            raise InvalidInputError("machine model", f"schema {MODEL_SCHEMA!r}", repr(got))
        try:
            tetra = data["tetrahedron"]
            sliders = {arm: SliderLine(**tetra["sliders"][arm]) for arm in ARMS}
            columns = {arm: ColumnLine(**data["columns"][arm]) for arm in ARMS}
            return cls(
                Tetrahedron(sliders, tetra["tip_centre"]),
                columns,
                reference_lasers=data.get("reference_lasers", np.full(3, 100.0)),
                reference_heights=data.get("reference_heights", np.zeros(3)),
                limits=None if data.get("limits") is None else MachineLimits.from_dict(data["limits"]),
            )
        except InvalidInputError:
            raise
        except (KeyError, TypeError, AttributeError, IndexError, ValueError, OverflowError) as exc:
            expected = "tetrahedron/sliders/columns for arms a, b, c"
            raise InvalidInputError("machine model", expected, repr(exc)) from None


def seed_machine(
    *,
    dead_distance: Mapping[str, float] | None = None,
    beta_deg: Mapping[str, float] | None = None,
    column_points: Mapping[str, ArrayLike] | None = None,
    column_slopes: Mapping[str, ArrayLike] | None = None,
    start_of_range: float = START_OF_RANGE,
    reference_lasers: ArrayLike | None = None,
    reference_height: float = 400.0,
    limits: MachineLimits | None = None,
) -> RigidBodyMachine:
    """Rigid-body machine with the seed's geometry: slider lines meeting at the tip.

    Parameters
    ----------
    dead_distance : mapping arm -> mm, optional
        ``d_i`` (Table 3.1 by default); the slider offset is ``start_of_range + d_i``.
    beta_deg : mapping "ab", "bc", "ca" -> degrees, optional
        Angles between arms (Table 3.1 by default).
    column_points : mapping arm -> (x, y) or (x, y, z), optional
        Column intercepts ``(g_i, m_i)`` (Appendix D's pivot x, y by default).
    column_slopes : mapping arm -> (h, n), optional
        Column slopes of eqs 2.19-2.20 (vertical by default).  The encoder scale is set
        so that the height reading equals the pivot's machine ``z``.
    start_of_range : float
        Laser start of range (60 mm).
    reference_lasers : array_like, shape (3,), optional
        Laser readings of the reference configuration.  Default: the configuration with
        all three pivots level at ``reference_height`` (the park position, see ``limits``).
    reference_height : float
        Pivot height of the reference configuration (mm); with explicit
        ``reference_lasers`` it is the starting height only.
    limits : MachineLimits, optional
        Default :meth:`MachineLimits.seed` (travel 277.22-727.22 mm, lasers 0-200 mm); pass
        ``MachineLimits.seed([h] * 3)`` when ``reference_height`` h is the park position.

    Returns
    -------
    RigidBodyMachine

    Examples
    --------
    >>> m = seed_machine()
    >>> sorted(m.columns), round(float(m.reference_heights.mean()), 6)
    (['a', 'b', 'c'], 400.0)
    """
    tetrahedron, columns, guess = seed_parts(
        dead_distance=dead_distance, beta_deg=beta_deg, column_points=column_points, column_slopes=column_slopes,
        start_of_range=start_of_range,
    )
    provisional = RigidBodyMachine(
        tetrahedron, columns, reference_lasers=guess, reference_heights=np.full(3, reference_height)
    )
    if reference_lasers is None:  # level pivots at reference_height
        solved = provisional.forward(heights=np.full(3, reference_height), check_limits=False)
    else:
        solved = provisional.forward(
            lasers=np.asarray(reference_lasers, dtype=float), heights_hint=np.full(3, reference_height),
            check_limits=False,
        )
    return RigidBodyMachine(
        provisional.tetrahedron, columns, reference_lasers=solved.lasers, reference_heights=solved.heights,
        limits=limits,
    )
