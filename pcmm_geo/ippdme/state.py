"""Server-wide state that outlives a session: tools and their parameter blocks, coordinate systems.

Spec §6.3.1.2: the active tool and the active coordinate system are kept from one session to
the next.  Tools (spec §6.3.2.14): ``RefTool`` and ``Probe1`` are the micro-CMM's fixed
ball stylus (calibrated radius), ``NoTool`` moves but does not measure.  Parameter blocks
(spec §6.3.6): ``Act`` values within ``[Min, Max]``; a value outside is clamped with warning
0504; ``Act`` returns to ``Def`` when the tool changes.

Coordinate systems (spec §6.3.3): positions go to the client in the active system, ``MachineCsy``
or a system with a transformation ``(X0, Y0, Z0, Theta, Psi, Phi)`` (mm, degrees):
``p_csy = R (p_machine - X0)`` with ``R = R_z(Phi) R_x(Theta) R_z(Psi)`` in the spec's
passive-rotation convention.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["CSY_NAMES", "CoordinateSystems", "ParameterBlock", "Tool", "ToolSet", "euler_matrix"]

FloatArray = NDArray[np.float64]
#: coordinate systems a client may select (SetCoordSystem) and transform (Set/GetCsyTransformation)
CSY_NAMES = ("MachineCsy", "MoveableMachineCsy", "MultipleArmCsy", "PartCsy")
TRANSFORM_NAMES = ("PartCsy", "JogDisplayCsy", "JogMoveCsy", "SensorCsy", "MoveableMachineCsy", "MultipleArmCsy")


@dataclass
class Limit:
    """One settable value: ``Act`` within ``[Min, Max]``, ``Def`` its default (units of the quantity)."""

    low: float
    high: float
    default: float
    act: float = float("nan")

    def __post_init__(self) -> None:
        self.act = self.default

    def set(self, value: float) -> bool:
        """Set ``Act``, clamped to the range; True if the value had to be clamped (warning 0504)."""
        clamped = min(max(value, self.low), self.high)
        self.act = clamped
        return clamped != value

    def get(self, sub: str) -> float | None:
        return {"Act": self.act, "": self.act, "Min": self.low, "Max": self.high, "Def": self.default}.get(sub)


@dataclass
class ParameterBlock:
    """``GoToPar`` or ``PtMeasPar``: name -> :class:`Limit` (Speed mm/s, Accel mm/s^2, distances mm)."""

    values: dict[str, Limit]

    def reset(self) -> None:
        for limit in self.values.values():
            limit.act = limit.default


def _goto() -> ParameterBlock:
    return ParameterBlock({"Speed": Limit(0.1, 20.0, 10.0), "Accel": Limit(1.0, 200.0, 50.0)})


def _ptmeas() -> ParameterBlock:
    return ParameterBlock({
        "Speed": Limit(0.01, 5.0, 1.0), "Accel": Limit(1.0, 200.0, 20.0),
        "Approach": Limit(0.1, 20.0, 2.0), "Search": Limit(0.1, 20.0, 4.0), "Retract": Limit(-1.0, 20.0, 2.0),
    })


@dataclass
class Tool:
    """A tool: ``name``, ``radius`` (mm, the calibrated ball; 0 for NoTool), ``measures`` and its blocks."""

    name: str
    radius: float
    measures: bool
    goto: ParameterBlock = field(default_factory=_goto)
    ptmeas: ParameterBlock = field(default_factory=_ptmeas)


class ToolSet:
    """The tool changer: visible tools (EnumTools order), the active tool and FindTool's pointer."""

    def __init__(self, tip_radius: float) -> None:
        self.tools = {
            "RefTool": Tool("RefTool", tip_radius, True),
            "NoTool": Tool("NoTool", 0.0, False),
            "Probe1": Tool("Probe1", tip_radius, True),
        }
        self.active = "Probe1"
        self.found: str | None = None

    @property
    def tool(self) -> Tool:
        return self.tools[self.active]

    def change(self, name: str) -> bool:
        """Activate ``name``; False if no such tool (1502).  The new tool's ``Act`` values return to ``Def``."""
        if name not in self.tools:
            return False
        self.active = name
        self.tools[name].goto.reset()
        self.tools[name].ptmeas.reset()
        return True


def euler_matrix(theta_deg: float, psi_deg: float, phi_deg: float) -> FloatArray:
    """``R = R_z(phi) R_x(theta) R_z(psi)`` (spec §6.3.3, passive rotations), angles in degrees."""
    t, p, f = (math.radians(a) for a in (theta_deg, psi_deg, phi_deg))

    def rz(a: float) -> FloatArray:
        return np.array([[math.cos(a), math.sin(a), 0.0], [-math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])

    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(t), math.sin(t)], [0.0, -math.sin(t), math.cos(t)]])
    return rz(f) @ rx @ rz(p)


class CoordinateSystems:
    """Active system and the stored transformations ``(X0, Y0, Z0 mm, Theta, Psi, Phi deg)``."""

    def __init__(self) -> None:
        self.active = "MachineCsy"
        self.transforms: dict[str, tuple[float, ...]] = {name: (0.0,) * 6 for name in TRANSFORM_NAMES}

    def set_transform(self, name: str, values: tuple[float, ...]) -> bool:
        """Store a transformation; False if Theta is outside [0, 180] degrees (1007).  Psi, Phi taken modulo 360."""
        x0, y0, z0, theta, psi, phi = values
        if not 0.0 <= theta <= 180.0:
            return False
        self.transforms[name] = (x0, y0, z0, theta, psi % 360.0, phi % 360.0)
        return True

    def _frame(self) -> tuple[FloatArray, FloatArray]:
        if self.active == "MachineCsy":
            return np.zeros(3), np.eye(3)
        x0, y0, z0, theta, psi, phi = self.transforms[self.active]
        return np.array([x0, y0, z0]), euler_matrix(theta, psi, phi)

    def to_client(self, point: FloatArray) -> FloatArray:
        origin, rotation = self._frame()
        return rotation @ (np.asarray(point, float) - origin)

    def to_machine(self, point: FloatArray) -> FloatArray:
        origin, rotation = self._frame()
        return rotation.T @ np.asarray(point, float) + origin

    def direction_to_client(self, vector: FloatArray) -> FloatArray:
        return self._frame()[1] @ np.asarray(vector, float)

    def direction_to_machine(self, vector: FloatArray) -> FloatArray:
        return self._frame()[1].T @ np.asarray(vector, float)
