"""Scripted I++ DME sessions over loopback: the issue's session, errors, vanishing and second clients, hostile lines."""

from __future__ import annotations

import socket
import time

import numpy as np
import pytest
from conftest import running_server
from ipp_client import IppClient, num

from pcmm_geo.ippdme.workpieces import SphereWorkpiece


def test_scripted_session_then_vanishing_client_then_new_session(model, center) -> None:
    with running_server(model, [SphereWorkpiece(center, 20.0)]) as server:
        c = IppClient(server.port)
        assert c.send("StartSession()").errors == []
        before = c.send("PtMeas(X(0), Y(0), Z(0), IJK(0,0,1))")
        assert before.numbers == [508] and before.complete
        assert c.send("ClearAllErrors()").errors == []
        assert c.send("Home()").errors == []
        assert c.send("IsHomed()").data == ["IsHomed(1)"]
        assert c.send("GetDMEVersion()").data == ['DMEVersion("1.4.3")']
        home = c.send("Get(X(), Y(), Z())").values()
        np.testing.assert_allclose([home["X"][0], home["Y"][0], home["Z"][0]], server.machine.home_position, atol=2e-6)
        assert c.send("EnumTools()").data == ['"RefTool"', '"NoTool"', '"Probe1"']
        target = center + np.array([3.0, -2.0, 20.0])
        assert c.send(f"GoTo(X({num(target[0])}), Y({num(target[1])}), Z({num(target[2])}))").errors == []
        where = c.send("Get(X(), Y(), Z())").values()
        np.testing.assert_allclose([where["X"][0], where["Y"][0], where["Z"][0]], target, atol=2e-6)
        unknown = c.send("Frobnicate(1)")
        assert unknown.numbers == [507]
        assert c.send("IsHomed()").numbers == [514]  # severity 3: ClearAllErrors first (spec 6.2.5)
        c.send("ClearAllErrors()")
        c.raw(b"garbage\x01\xff line\r\n")
        line = c.readline()
        assert line.startswith("E0000 ! Error(3, 0001") or line.startswith("E0000 ! Error(3, 0007"), line
        c.send("ClearAllErrors()")
        assert c.send("IsHomed()").data == ["IsHomed(1)"]
        # the session goes on: a probing on the sphere's top
        top = center + np.array([0.0, 0.0, 10.0])
        reply = c.send(f"PtMeas(X({num(top[0])}), Y({num(top[1])}), Z({num(top[2])}), IJK(0,0,1))")
        assert reply.errors == []
        z = reply.values()["Z"][0]
        assert abs(z - top[2]) < 0.005  # within the machine's errors (um level), not a nominal echo test
        assert c.send("EndSession()").errors == []
        # a client that vanishes mid-move (slow motion), then a new one
        c.send("StartSession()")
        c.raw(f"99999 GoTo(Z({num(home['Z'][0])}))\r\n".encode())
        c.close()
    # server and state after the vanished client: a new client gets a fresh session
    with running_server(model, [SphereWorkpiece(center, 20.0)], time_scale=1.0) as server:
        c = IppClient(server.port)
        c.send("StartSession()")
        server.machine.homed = True  # homed by an earlier session (the 40 mm homing travel would take 4 s here)
        c.send("SetProp(Tool.GoToPar.Speed(1))")
        far = server.machine.position + np.array([0.0, 0.0, -5.0])
        c.raw(f"00100 GoTo(Z({num(far[2])}))\r\n".encode())
        assert c.readline() == "00100 &"
        time.sleep(1.0)
        c.close()  # vanishes mid-move (5 s at 1 mm/s)
        time.sleep(0.3)
        stopped = server.machine.position.copy()
        assert -5.0 < stopped[2] - (far[2] + 5.0) < -0.1  # moved some, stopped where it was
        d = IppClient(server.port)
        assert d.send("StartSession()").errors == []  # the old session ended with its client
        assert d.send("IsHomed()").data == ["IsHomed(1)"]  # machine state kept
        got = d.send("Get(X(), Y(), Z())").values()
        assert abs(got["Z"][0] - stopped[2]) < 1e-5
        d.send("EndSession()")
        d.close()


def test_second_client_is_refused_while_the_first_holds_the_server(model, center) -> None:
    with running_server(model, [SphereWorkpiece(center, 20.0)]) as server:
        first = IppClient(server.port)
        first.send("StartSession()")
        second = IppClient(server.port)
        line = second.readline()
        assert line.startswith("E0000 ! Error(3, 0008"), line
        with pytest.raises(ConnectionError):
            second.readline()
        assert first.send("IsHomed()").data == ["IsHomed(0)"]
        first.close()
        time.sleep(0.2)
        third = IppClient(server.port)
        assert third.send("StartSession()").errors == []
        third.close()


def test_hostile_lines_overlong_binary_flood(model, center) -> None:
    with running_server(model, [SphereWorkpiece(center, 20.0)]) as server:
        c = IppClient(server.port)
        c.send("StartSession()")
        hostile = ((b"0001 Home()", 1), (b"00001Home()", 2), (b"00002 Home(", 502), (b"00003 GoTo(X(1e999))", 502),
                   (b"00004 GoTo(X(12345678901234567))", 502), (b"E0000 Home()", 1), (b"00005 Home()\x00", 7))
        for bad, number in hostile:
            c.raw(bad + b"\r\n")
            lines = []
            while not any(" ! " in x for x in lines):
                lines.append(c.readline())
            assert f", {number:04d}," in lines[-1], (bad, lines)
            if not lines[-1].startswith("E0000"):
                assert c.readline().endswith(" %")
            c.send("ClearAllErrors()")
        # a flood of 500 commands in one write: all answered, in order
        c.raw(b"".join(f"{i:05d} IsHomed()\r\n".encode() for i in range(1000, 1500)))
        seen = [c.collect(f"{i:05d}") for i in range(1000, 1500)]
        assert all(r.data == ["IsHomed(0)"] for r in seen)
        # an over-long line: the error, then the connection is closed; the server stays up
        c.raw(b"00010 Get(" + b"X()," * 20000 + b"X())\r\n")
        line = c.readline()
        assert line.startswith("E0000 ! Error(3, 0008"), line
        with pytest.raises((ConnectionError, OSError)):
            c.readline()
        d = IppClient(server.port)
        assert d.send("StartSession()").errors == []
        d.close()
    # a client that sends and never reads is dropped after the write timeout; the server stays up
    with running_server(model, [], write_timeout=0.5) as server:
        s = socket.create_connection(("127.0.0.1", server.port))
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        s.sendall(b"00001 StartSession()\r\n" + b"".join(f"{i:05d} EnumTools()\r\n".encode() for i in range(2, 20000)))
        time.sleep(1.5)
        s.close()
        time.sleep(0.2)
        d = IppClient(server.port)
        assert d.send("StartSession()").errors == []
        d.close()


def test_abort_stops_a_move_and_requires_clear_all_errors(model, center) -> None:
    with running_server(model, [], time_scale=1.0) as server:
        c = IppClient(server.port)
        c.send("StartSession()")
        server.machine.homed = True  # skip the homing travel
        c.send("SetProp(Tool.GoToPar.Speed(1))")
        start = server.machine.position.copy()
        c.raw(f"00050 GoTo(Z({num(start[2] + 10)}))\r\n00051 IsHomed()\r\n".encode())
        assert c.readline() == "00050 &"
        assert c.readline() == "00051 &"
        move = c.send("OnMoveReportE(Time(0.1), Z())", event=True)
        assert move.errors == []
        time.sleep(0.8)
        abort = c.send("AbortE()", event=True)
        assert abort.errors == []
        events = [x for x in c.other if x.startswith(move.lines[0][:5] + " #")]
        assert events, c.other
        moving = [x for x in c.other if x.startswith("00050 ") or x.startswith("00051 ")]
        assert "00050 %" in moving and "00051 %" in moving
        assert any(", 0006," in x for x in moving if x.startswith("00050 !"))
        assert any(", 0006," in x for x in moving if x.startswith("00051 !"))
        z = server.machine.position[2] - start[2]
        assert 0.1 < z < 9.0
        assert c.send("IsHomed()").numbers == [514]
        assert c.send("GetErrStatusE()", event=True).data == ["ErrStatus(1)"]
        c.send("ClearAllErrors()")
        assert c.send("IsHomed()").data == ["IsHomed(1)"]
        assert c.send("StopAllDaemons()").errors == []
        assert c.send("StopAllDaemons()").numbers == [512]  # a warning (severity 1): no error state
        assert c.send("IsHomed()").errors == []
        c.close()


def _rotation(theta: float, psi: float, phi: float) -> np.ndarray:
    """Spec §6.3.3: x''' = R(phi) R(theta) R(psi) x, written out here independently (degrees in)."""
    t, p, f = np.radians([theta, psi, phi])
    r_psi = np.array([[np.cos(p), np.sin(p), 0], [-np.sin(p), np.cos(p), 0], [0, 0, 1]])
    r_theta = np.array([[1, 0, 0], [0, np.cos(t), np.sin(t)], [0, -np.sin(t), np.cos(t)]])
    r_phi = np.array([[np.cos(f), np.sin(f), 0], [-np.sin(f), np.cos(f), 0], [0, 0, 1]])
    return r_phi @ r_theta @ r_psi


def test_part_coordinate_system_tools_and_properties(model, center) -> None:
    with running_server(model, [SphereWorkpiece(center, 20.0)]) as server:
        c = IppClient(server.port)
        c.send("StartSession()")
        c.send("Home()")
        origin, angles = np.array([-10.0, 2.0, 80.0]), (30.0, 400.0, -20.0)
        reply = c.send(f"SetCsyTransformation(PartCsy, {', '.join(num(v) for v in (*origin, *angles))})")
        assert reply.errors == []
        back = c.send("GetCsyTransformation(PartCsy)").values()["GetCsyTransformation"]
        np.testing.assert_allclose(back, [*origin, 30.0, 40.0, 340.0], atol=1e-6)  # Psi, Phi modulo 360
        assert c.send("SetCsyTransformation(PartCsy, 0, 0, 0, 181, 0, 0)").numbers == [1007]
        c.send("ClearAllErrors()")
        assert c.send("SetCoordSystem(PartCsy)").errors == []
        assert c.send("GetCoordSystem()").data == ["CoordSystem(PartCsy)"]
        rotation = _rotation(30.0, 40.0, 340.0)
        got = c.send("Get(X(), Y(), Z())").values()
        expected = rotation @ (server.machine.position - origin)
        np.testing.assert_allclose([got["X"][0], got["Y"][0], got["Z"][0]], expected, atol=2e-6)
        # a GoTo in part coordinates ends at the machine point the transformation gives
        machine_target = center + np.array([5.0, 5.0, 25.0])
        part_target = rotation @ (machine_target - origin)
        assert c.send(f"GoTo(X({num(part_target[0])}), Y({num(part_target[1])}), Z({num(part_target[2])}))"
                      ).errors == []
        np.testing.assert_allclose(server.machine.position, machine_target, atol=2e-6)
        c.send("SetCoordSystem(MachineCsy)")
        # tools and properties
        assert c.send('ChangeTool("Probe2")').numbers == [1502]
        c.send("ClearAllErrors()")
        assert c.send('FindTool("RefTool")').errors == []
        names = c.send("GetProp(FoundTool.Name(), Tool.Name())").data
        assert names == ['FoundTool.Name("RefTool"), Tool.Name("Probe1")']
        clamp = c.send("SetProp(Tool.PtMeasPar.Approach(50), Tool.GoToPar.Speed(5))")
        assert clamp.numbers == [504] and clamp.errors[0][0] == 1  # a warning: the session goes on
        values = c.send("GetProp(Tool.PtMeasPar.Approach(), Tool.PtMeasPar.Approach.Max(), Tool.GoToPar.Speed())")
        assert values.values() == {"Tool.PtMeasPar.Approach": [20.0], "Tool.PtMeasPar.Approach.Max": [20.0],
                                   "Tool.GoToPar.Speed": [5.0]}
        assert c.send("SetProp(Tool.AvrRadius(2))").numbers == [510]  # read-only
        c.send("ClearAllErrors()")
        radius = c.send("GetProp(Tool.AvrRadius())").values()["Tool.AvrRadius"][0]
        assert abs(radius - model.tip_radius) < 1e-6
        assert c.send('ChangeTool("NoTool")').errors == []
        top = center + np.array([0.0, 0.0, 10.0])
        assert c.send(f"PtMeas(X({num(top[0])}), Y({num(top[1])}), Z({num(top[2])}), IJK(0,0,1))").numbers == [2002]
        c.send("ClearAllErrors()")
        c.send('ChangeTool("Probe1")')
        assert c.send("GetProp(Tool.PtMeasPar.Approach())").values()["Tool.PtMeasPar.Approach"] == [2.0]  # Def again
        assert c.send("AlignTool(0, 0, 1, 5)").data == ["(0.000000, 0.000000, 1.000000)"]
        assert c.send("AlignTool(1, 0, 0, 5)").numbers == [1502]
        c.send("ClearAllErrors()")
        assert c.send("AlignPart(0, 0, 1, 1)").numbers == [501]
        c.send("ClearAllErrors()")
        # a probing whose search finds nothing: 1006, and the machine stops at the end of the search
        air = center + np.array([0.0, 0.0, 30.0])
        assert c.send(f"PtMeas(X({num(air[0])}), Y({num(air[1])}), Z({num(air[2])}), IJK(0,0,1))").numbers == [1006]
        c.close()
