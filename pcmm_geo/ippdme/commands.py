"""Handlers of the I++ DME methods the micro-CMM supports (spec §6.3), one coroutine per method.

A handler receives the session (:class:`pcmm_geo.ippdme.session.Session`) and the parsed
command, sends its data lines with ``session.data(cmd, text)`` and raises :class:`CommandError`
with a spec error number for anything it refuses.  The session sends the error line and the
transaction complete.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

import numpy as np

from pcmm_geo.ippdme.machine import MoveRefused
from pcmm_geo.ippdme.protocol import Command, EventTag, Name, Property, Text, format_number
from pcmm_geo.ippdme.state import CSY_NAMES, TRANSFORM_NAMES

#: the session a handler runs in (:class:`pcmm_geo.ippdme.session.Session`; not imported: it imports this module)
Session = Any
__all__ = ["HANDLERS", "KNOWN_METHODS", "CommandError"]

Handler = Callable[[Any, Command], Awaitable[None]]
#: items allowed in OnPtMeasReport (spec §6.3.2.6) and in Get / OnMoveReportE
_REPORT_ITEMS = ("X", "Y", "Z", "IJK", "ER", "Q", "Tool.A", "Tool.B", "Tool.C")
_POSITION_ITEMS = ("X", "Y", "Z", "Tool.A", "Tool.B", "Tool.C")
#: quality Q() of a point (spec §6.3.2.24: 0 good .. 100 bad) flagged poorly resolved
POORLY_RESOLVED_Q = 50


class CommandError(Exception):
    """Refusal of a command with a spec error number (:data:`pcmm_geo.ippdme.protocol.ERRORS`)."""

    def __init__(self, number: int, detail: str = "") -> None:
        super().__init__(detail)
        self.number = number
        self.detail = detail


def _no_args(cmd: Command) -> None:
    if cmd.args:
        raise CommandError(502, f"{cmd.method} takes no arguments")


def _text(cmd: Command) -> str:
    if len(cmd.args) != 1 or not isinstance(cmd.args[0], Text):
        raise CommandError(502, f'{cmd.method} takes one quoted name, e.g. {cmd.method}("Probe1")')
    return cmd.args[0].value


def _empty_properties(cmd: Command, allowed: tuple[str, ...]) -> list[str]:
    names = []
    for arg in cmd.args:
        if not isinstance(arg, Property) or arg.values or arg.name not in allowed:
            raise CommandError(510, f"{arg!r} is not one of {', '.join(n + '()' for n in allowed)}")
        if arg.name in names:
            raise CommandError(509, f"{arg.name}() appears twice")
        names.append(arg.name)
    if not names:
        raise CommandError(510, "the enumeration may not be empty")
    return names


def format_position(session: Session, items: list[str], point: np.ndarray) -> str:
    """``X(x), Y(y), Z(z)`` etc. of a machine-frame tip position in the active coordinate system."""
    client = session.state.csy.to_client(point)
    parts = []
    for item in items:
        if item in ("X", "Y", "Z"):
            parts.append(f"{item}({format_number(client['XYZ'.index(item)])})")
        else:  # fixed stylus: no articulating head
            parts.append(f"{item}({format_number(0.0)})")
    return ", ".join(parts)


# ---------------------------------------------------------------------------------------- session
async def start_session(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    if s.active:
        raise CommandError(8, "a session is already active (EndSession first)")
    s.begin()


async def end_session(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    s.end()


async def clear_all_errors(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    s.clear_errors()


async def get_err_status(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    await s.data(cmd, f"ErrStatus({1 if s.error_severity >= 2 or s.aborted else 0})")


async def get_xtd_err_status(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    await s.data(cmd, f"IsHomed({int(s.machine.homed)})")
    await s.data(cmd, f"IsUserEnabled({int(s.user_enabled)})")
    for number, text in s.errors:
        await s.data(cmd, f'"{number:04d}", "{text}"')


async def get_dme_version(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    await s.data(cmd, 'DMEVersion("1.4.3")')


async def get_machine_class(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    await s.data(cmd, 'GetMachineClass("CartCMM")')


async def enable_user(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    s.user_enabled = cmd.method == "EnableUser"


async def is_user_enabled(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    await s.data(cmd, f"IsUserEnabled({int(s.user_enabled)})")


# ---------------------------------------------------------------------------------------- motion
async def home(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    s.user_enabled = False
    await s.machine.home(s, s.tools.tool.goto.values["Speed"].act)


async def is_homed(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    await s.data(cmd, f"IsHomed({int(s.machine.homed)})")


def _target(s: Session, cmd: Command, allowed: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray | None]:
    """Target point (machine frame) from X(x), Y(y), Z(z) (missing axes keep their value) and IJK."""
    client = s.state.csy.to_client(s.machine.position)
    ijk = None
    given = set()
    for arg in cmd.args:
        if not isinstance(arg, Property) or arg.name not in allowed:
            raise CommandError(506, f"{arg!r} is not supported by {cmd.method} (use {', '.join(allowed)})")
        if arg.name in given:
            raise CommandError(509, f"{arg.name} appears twice")
        given.add(arg.name)
        if arg.name == "IJK":
            if len(arg.values) != 3:
                raise CommandError(509, "IJK takes three numbers")
            ijk = np.asarray(arg.values, dtype=float)
        else:
            if len(arg.values) != 1:
                raise CommandError(509, f"{arg.name} takes one number")
            client["XYZ".index(arg.name)] = arg.values[0]
    if not given - {"IJK"}:
        raise CommandError(509, f"{cmd.method} needs at least one of X(), Y(), Z()")
    return s.state.csy.to_machine(client), ijk


async def goto(s: Session, cmd: Command) -> None:
    if not s.machine.homed:
        raise CommandError(508, "the machine is not homed (Home first)")
    target, _ = _target(s, cmd, ("X", "Y", "Z"))
    s.user_enabled = False
    await s.travel(target, s.tools.tool.goto.values["Speed"].act)


async def get(s: Session, cmd: Command) -> None:
    names = []
    for arg in cmd.args:
        if not isinstance(arg, Property) or arg.values or arg.name not in _POSITION_ITEMS:
            raise CommandError(509, f"Get takes X(), Y(), Z(), Tool.A(), Tool.B(), Tool.C(); got {arg!r}")
        if arg.name in names:  # an enumeration names each item once (spec 6.1.3)
            raise CommandError(509, f"{arg.name}() appears twice")
        names.append(arg.name)
    if not names:
        raise CommandError(509, "Get needs at least one item")
    await s.data(cmd, format_position(s, names, await s.machine.read_position(s)))


async def on_move_report(s: Session, cmd: Command) -> None:
    interval, distance, items = 1.0, float("inf"), []
    for arg in cmd.args:
        if isinstance(arg, Property) and arg.name in ("Time", "Dis") and len(arg.values) == 1:
            if arg.name == "Time":
                interval = max(0.1, arg.values[0])
            else:
                distance = arg.values[0]
        elif isinstance(arg, Property) and not arg.values and arg.name in _POSITION_ITEMS and arg.name not in items:
            items.append(arg.name)
        else:
            raise CommandError(510, f"OnMoveReportE takes Time(s), Dis(mm) and X(), Y(), Z(); got {arg!r}")
    if not items:
        raise CommandError(510, "no item to report")
    if cmd.tag in s.daemons:
        raise CommandError(515, cmd.tag)
    s.daemons[cmd.tag] = (interval, distance, items)


async def stop_daemon(s: Session, cmd: Command) -> None:
    if len(cmd.args) != 1 or not isinstance(cmd.args[0], EventTag):
        raise CommandError(502, "StopDaemon takes one event tag, e.g. StopDaemon(E0001)")
    if s.daemons.pop(cmd.args[0].value, None) is None:
        raise CommandError(513, cmd.args[0].value)


async def stop_all_daemons(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    if not s.daemons:
        raise CommandError(512)
    s.daemons.clear()


# ---------------------------------------------------------------------------------------- probing
async def on_ptmeas_report(s: Session, cmd: Command) -> None:
    s.report_items = _empty_properties(cmd, _REPORT_ITEMS)


async def ptmeas(s: Session, cmd: Command) -> None:
    if not s.machine.homed:
        raise CommandError(508, "the machine is not homed (Home first)")
    tool = s.tools.tool
    if not tool.measures:
        raise CommandError(2002, f"{tool.name} cannot measure")
    nominal, ijk = _target(s, cmd, ("X", "Y", "Z", "IJK"))
    if ijk is None:
        n = s.machine.position - nominal
    else:
        n = s.state.csy.direction_to_machine(ijk)
    norm = float(np.linalg.norm(n))
    if not norm > 1e-12:
        raise CommandError(1010, "no probing direction (IJK or a position away from the target)")
    n = n / norm
    p = tool.ptmeas.values
    s.user_enabled = False
    start = nominal + n * (tool.radius + p["Approach"].act)
    await s.travel(start, tool.goto.values["Speed"].act)
    try:
        result = await s.machine.measure(s, nominal, n, approach=p["Approach"].act, search=p["Search"].act,
                                         retract=p["Retract"].act, speed=p["Speed"].act)
    except MoveRefused as exc:
        s.record_probe(cmd, None, exc)
        raise CommandError(exc.number, exc.detail) from None
    s.record_probe(cmd, result, None)
    parts = []
    for item in s.report_items:
        if item in ("X", "Y", "Z"):
            parts.append(f"{item}({format_number(s.state.csy.to_client(result.point)['XYZ'.index(item)])})")
        elif item == "IJK":
            v = s.state.csy.direction_to_client(result.direction)
            parts.append(f"IJK({', '.join(format_number(x) for x in v)})")
        elif item == "ER":
            parts.append(f"ER({format_number(result.effective_radius)})")
        elif item == "Q":
            parts.append(f"Q({POORLY_RESOLVED_Q if result.poorly_resolved else 0})")
        else:
            parts.append(f"{item}({format_number(0.0)})")
    await s.data(cmd, ", ".join(parts))
    # a retract between the contact and the approach point stays on the path just travelled
    on_path = float(np.linalg.norm(result.retract_position - s.machine.position)) <= float(
        np.linalg.norm(start - s.machine.position)) + 1e-9
    await s.travel(result.retract_position, tool.goto.values["Speed"].act, check=not on_path)


# ---------------------------------------------------------------------------------------- tools
async def enum_tools(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    for name in s.tools.tools:
        await s.data(cmd, f'"{name}"')


async def change_tool(s: Session, cmd: Command) -> None:
    if not s.tools.change(_text(cmd)):
        raise CommandError(1502, _text(cmd))
    if cmd.method == "ChangeTool":
        s.user_enabled = False


async def find_tool(s: Session, cmd: Command) -> None:
    name = _text(cmd)
    s.tools.found = name if name in s.tools.tools else None
    if s.tools.found is None:
        raise CommandError(1502, name)


def _property(s: Session, name: str) -> tuple[Any, str, str]:
    """(tool, block-or-attribute, sub) for ``Tool.X`` / ``FoundTool.X`` property names; 0510 otherwise."""
    head, _, rest = name.partition(".")
    if head == "FoundTool":
        if s.tools.found is None:
            raise CommandError(1503, "FoundTool is UnDefTool (FindTool first)")
        tool = s.tools.tools[s.tools.found]
    elif head == "Tool":
        tool = s.tools.tool
    else:
        raise CommandError(510, name)
    return tool, rest, name


async def get_prop(s: Session, cmd: Command) -> None:
    parts = []
    for arg in cmd.args:
        if not isinstance(arg, Property) or arg.values:
            raise CommandError(510, f"GetProp takes empty properties such as Tool.GoToPar.Speed(); got {arg!r}")
        tool, rest, name = _property(s, arg.name)
        if rest == "Name":
            parts.append(f'{name}("{tool.name}")')
            continue
        if rest == "AvrRadius":
            parts.append(f"{name}({format_number(tool.radius)})")
            continue
        block, _, key = rest.partition(".")
        key, _, sub = key.partition(".")
        values = {"GoToPar": tool.goto.values, "PtMeasPar": tool.ptmeas.values}.get(block, {})
        value = values[key].get(sub) if key in values else None
        if value is None:
            raise CommandError(510, name)
        parts.append(f"{name}({format_number(value)})")
    if not parts:
        raise CommandError(510, "GetProp needs at least one property")
    await s.data(cmd, ", ".join(parts))


async def set_prop(s: Session, cmd: Command) -> None:
    changes = []
    for arg in cmd.args:
        if not isinstance(arg, Property) or len(arg.values) != 1:
            raise CommandError(510, f"SetProp takes properties with one value, e.g. Tool.GoToPar.Speed(5); got {arg!r}")
        tool, rest, name = _property(s, arg.name)
        block, _, key = rest.partition(".")
        key, _, sub = key.partition(".")
        values = {"GoToPar": tool.goto.values, "PtMeasPar": tool.ptmeas.values}.get(block, {})
        if key not in values or sub not in ("", "Act"):
            raise CommandError(510, f"{name} is not settable (Speed, Accel, Approach, Search, Retract Act values)")
        changes.append((values[key], arg.values[0], name))
    if not changes:
        raise CommandError(510, "SetProp needs at least one property")
    clamped = [name for limit, value, name in changes if limit.set(value)]
    if clamped:
        await s.warn(cmd, 504, f"set to the nearest limit: {', '.join(clamped)}")


# ---------------------------------------------------------------------------------------- coordinates
async def set_coord_system(s: Session, cmd: Command) -> None:
    if len(cmd.args) != 1 or not isinstance(cmd.args[0], Name) or cmd.args[0].value not in CSY_NAMES:
        raise CommandError(509, f"SetCoordSystem takes one of {', '.join(CSY_NAMES)}")
    s.state.csy.active = cmd.args[0].value


async def get_coord_system(s: Session, cmd: Command) -> None:
    _no_args(cmd)
    await s.data(cmd, f"CoordSystem({s.state.csy.active})")


async def get_csy_transformation(s: Session, cmd: Command) -> None:
    if len(cmd.args) != 1 or not isinstance(cmd.args[0], Name) or cmd.args[0].value not in TRANSFORM_NAMES:
        raise CommandError(509, f"GetCsyTransformation takes one of {', '.join(TRANSFORM_NAMES)}")
    values = s.state.csy.transforms[cmd.args[0].value]
    await s.data(cmd, f"GetCsyTransformation({', '.join(format_number(v) for v in values)})")


async def set_csy_transformation(s: Session, cmd: Command) -> None:
    args = cmd.args
    if (len(args) != 7 or not isinstance(args[0], Name) or args[0].value not in TRANSFORM_NAMES
            or not all(isinstance(a, float) for a in args[1:])):
        raise CommandError(509, "SetCsyTransformation(PartCsy, X0, Y0, Z0, Theta, Psi, Phi)")
    if not s.state.csy.set_transform(args[0].value, tuple(float(a) for a in args[1:])):  # type: ignore[arg-type]
        raise CommandError(1007, f"Theta {args[5]} outside 0..180 degrees")


async def align_tool(s: Session, cmd: Command) -> None:
    """Fixed ball stylus: the primary direction is +Z (stylus pointing down); any secondary is reachable."""
    values = [a for a in cmd.args if isinstance(a, float)]
    if len(values) != len(cmd.args) or len(values) not in (4, 8):
        raise CommandError(502, "AlignTool(i, j, k, alpha) or AlignTool(i1, j1, k1, i2, j2, k2, alpha, beta)")
    primary = np.asarray(values[0:3])
    if not np.linalg.norm(primary) > 0:
        raise CommandError(1010, "first vector")
    alpha = values[3] if len(values) == 4 else values[6]
    reached = np.array([0.0, 0.0, 1.0])
    requested = s.state.csy.direction_to_machine(primary / np.linalg.norm(primary))
    angle = float(np.degrees(np.arccos(np.clip(requested @ reached, -1.0, 1.0))))
    if alpha > 0 and angle > alpha:
        raise CommandError(1502, f"the fixed stylus is {angle:.1f} deg from the requested direction")
    out = list(s.state.csy.direction_to_client(reached))
    if len(values) == 8:
        second = np.asarray(values[3:6])
        second = second - (second @ out) * np.asarray(out)
        if not np.linalg.norm(second) > 0:
            raise CommandError(1010, "second vector")
        out += list(second / np.linalg.norm(second))
    await s.data(cmd, f"({', '.join(format_number(v) for v in out)})")


HANDLERS: dict[str, Handler] = {
    "StartSession": start_session, "EndSession": end_session, "ClearAllErrors": clear_all_errors,
    "GetErrStatusE": get_err_status, "GetXtdErrStatus": get_xtd_err_status, "GetDMEVersion": get_dme_version,
    "GetMachineClass": get_machine_class, "EnableUser": enable_user, "DisableUser": enable_user,
    "IsUserEnabled": is_user_enabled, "Home": home, "IsHomed": is_homed, "GoTo": goto, "Get": get,
    "OnMoveReportE": on_move_report, "StopDaemon": stop_daemon, "StopAllDaemons": stop_all_daemons,
    "OnPtMeasReport": on_ptmeas_report, "PtMeas": ptmeas, "EnumTools": enum_tools, "ChangeTool": change_tool,
    "SetTool": change_tool, "FindTool": find_tool, "GetProp": get_prop, "GetPropE": get_prop,
    "SetProp": set_prop, "SetCoordSystem": set_coord_system, "GetCoordSystem": get_coord_system,
    "GetCsyTransformation": get_csy_transformation, "SetCsyTransformation": set_csy_transformation,
    "AlignTool": align_tool,
}

#: methods of spec 1.4.3 this server does not implement (answered 0501); any other name is 0507
KNOWN_METHODS = frozenset({
    "AbortE", "GetErrorInfo", "EnumProp", "EnumAllProp", "SetPropE", "GetChangeToolAction", "ReQualify",
    "AlignPart", "CenterPart", "TiltPart", "TiltCenterPart", "LockAxis", "OnScanReport", "ScanOnCircle",
    "ScanOnCircleHint", "ScanOnLine", "ScanOnLineHint", "ScanInPlaneEndIsSphere", "ScanInPlaneEndIsPlane",
    "ScanInPlaneEndIsCyl", "ScanInCylEndIsSphere", "ScanInCylEndIsPlane", "ScanInCylEndIsCyl", "ScanUnknownHint",
    "ScanUnknownDensity", "ScanOnCurve", "ScanOnCurveHint", "ScanOnCurveDensity", "ScanOnHelix", "GoToE",
    "PtMeasE", "ChangeToolE", "KeyPressE", "Tool", "FoundTool", "GoToPar", "PtMeasPar", "ScanPar",
    "SaveActiveCoordSystem",
    "LoadCoordSystem", "SaveCoordSystem", "DeleteCoordSystem", "EnumCoordSystems", "GetNamedCsyTransformation",
    "SetNamedCsyTransformation", "IJK", "X", "Y", "Z", "R", "ER", "Q",
}) | frozenset(HANDLERS)
