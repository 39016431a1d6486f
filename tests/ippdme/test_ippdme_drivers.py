"""The I++ DME server in front of the real drivers: a TCP client -> server -> drivers over ptys -> simulated devices.

The simulated rig (:class:`pcmm_geo.acquisition.simulators.cmm.SimulatedRig`) runs the demo's
*true* machine; the server runs the demo's *calibrated* model, so the points carry the
calibration's error.  Independent truth: the sphere placed in the simulator, the simulator's
own tip at the motor counts, and the calibration covariance's spread along the probing
direction (draws of the true machine, as the simulated backend makes them).
"""

from __future__ import annotations

import contextlib
import json
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from ipp_client import IppClient, num

from pcmm_geo.errors import DeviceError, DeviceTimeoutError, InvalidInputError

SPHERE_OFFSET = np.array([25.0, 0.0, 0.0])  # beside the tip's vertical homing line
SPHERE_DIAMETER = 20.0
#: fast settings for the simulated stages, which stop at the contact microstep themselves (a real probe is polled:
#: its trigger is seen up to one step late, the defaults' fine step is 0.01 mm)
FAST = {"move_step_mm": 2.0, "search_step_mm": 0.5, "fine_step_mm": 0.1, "back_off_mm": 0.6}


class _SphereClearance:
    """The sphere as the simulated rig sees it: ``clearance(tip) <= ball radius`` is contact."""

    def __init__(self, center: np.ndarray, diameter: float) -> None:
        self.center, self.radius = center, diameter / 2.0

    def clearance(self, points: Any) -> np.ndarray:
        return np.linalg.norm(np.asarray(points, dtype=float) - self.center, axis=-1) - self.radius


@contextlib.contextmanager
def driver_server(model: Any, *, transport: str, transcript: Any = None, fault_rate: float = 0.0,
                  seed: int = 0) -> Iterator[tuple[Any, Any, Any]]:
    """(server, rig, machine): the server on a DriverMachine over the rig's ports (pty or virtual)."""
    from pcmm_geo.acquisition.simulators.cmm import SimulatedMicroCMM, SimulatedRig
    from pcmm_geo.demo import DemoSettings, true_machine
    from pcmm_geo.ippdme.drivers import StepSettings, open_driver_machine
    from pcmm_geo.ippdme.server import ServerThread
    from pcmm_geo.ippdme.session import ServerState
    from pcmm_geo.ippdme.transcript import Transcript

    with contextlib.ExitStack() as stack:
        rig = stack.enter_context(SimulatedRig(SimulatedMicroCMM(machine=true_machine(DemoSettings())),
                                               transport=transport, fault_rate=fault_rate, seed=seed, silence=0.4))
        machine = open_driver_machine(model, rig.ports, stack, timeout=0.2, move_timeout=5.0, clock=rig.clock,
                                      settings=StepSettings(**FAST))
        transcript = transcript if transcript is not None else Transcript(None, {})
        with ServerThread(ServerState.create(machine), transcript) as server:
            yield server, rig, machine


def _reconnect(port: int) -> IppClient:
    """A new client with a session, once the server has seen the previous one go (one client at a time)."""
    for _ in range(50):
        client = IppClient(port)
        try:
            assert client.send("StartSession()").errors == []
            return client
        except ConnectionError:
            client.close()
            time.sleep(0.05)
    raise AssertionError("the server never took a new client")


def _ptmeas(client: IppClient, point: np.ndarray, normal: np.ndarray) -> Any:
    return client.send(f"PtMeas(X({num(point[0])}), Y({num(point[1])}), Z({num(point[2])}), "
                       f"IJK({num(normal[0])}, {num(normal[1])}, {num(normal[2])}))")


def _calibration_spread(model: Any, heights: np.ndarray, normals: np.ndarray, draws: int = 48) -> np.ndarray:
    """Standard deviation over draws of the true machine of the point error along each normal (mm)."""
    from pcmm_geo.ippdme.machine import SimulatedMachine

    calibrated = model.machine.forward(heights=heights, lasers_hint=model.machine.reference_lasers,
                                       check_limits=False).tip
    errors = []
    for seed in range(draws):
        sim = SimulatedMachine(model, seed=1000 + seed)
        true = sim.true_machine.forward(heights=heights, lasers_hint=model.machine.reference_lasers,
                                        check_limits=False).tip
        errors.append(np.sum((calibrated - true) * normals, axis=-1) + (sim.true_radius - model.tip_radius))
    return np.std(np.array(errors), axis=0)


def test_client_server_drivers_pty_sphere(model: Any, center: np.ndarray, tmp_path: Path) -> None:
    from pcmm_geo.ippdme.transcript import Transcript, measured_points, read_transcript

    transcript = Transcript(tmp_path / "t.jsonl", {"test": "drivers"})
    sphere = center + SPHERE_OFFSET
    with driver_server(model, transport="pty", transcript=transcript) as (server, rig, machine):
        client = IppClient(server.port)
        assert client.send("StartSession()").complete
        assert client.send("PtMeas(X(0), Y(0), Z(0), IJK(0, 0, 1))").numbers == [508]
        assert client.send("ClearAllErrors()").errors == []
        assert client.send("Home()").errors == []
        assert client.send("IsHomed()").data == ["IsHomed(1)"]
        # the rig's stages are at the home pose's counts; Get reads the lasers and counts back
        home_counts = machine.counts_of(model.machine.reference_heights + 40.0)
        assert [rig.zaber.positions[d] for d in (1, 2, 3)] == home_counts.tolist()
        got = client.send("Get(X(), Y(), Z())").values()
        reported = np.array([got["X"][0], got["Y"][0], got["Z"][0]])
        assert np.linalg.norm(reported - machine.home_position) < 0.01  # calibration + laser counts, um level
        assert np.linalg.norm(reported - rig.cmm.tip) < 0.01  # the simulator's own (true) tip
        rig.place_gauge_block(block=_SphereClearance(sphere, SPHERE_DIAMETER))  # the part, after homing
        above = sphere + np.array([0.0, 0.0, 20.0])
        assert client.send(f"GoTo(X({num(above[0])}), Y({num(above[1])}), Z({num(above[2])}))").errors == []
        assert client.send("SetProp(Tool.PtMeasPar.Approach(1), Tool.PtMeasPar.Search(2))").errors == []
        normals = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, 0.6, 0.8], [-0.6, 0.0, 0.8]])
        points = []
        for n in normals:
            reply = _ptmeas(client, sphere + SPHERE_DIAMETER / 2 * n, n)
            assert reply.errors == [], reply.lines
            v = reply.values()
            points.append([v["X"][0], v["Y"][0], v["Z"][0]])
        # nothing under a point in the air: the spec's 1006 after the whole search, and the session goes on
        air = sphere + np.array([0.0, 0.0, 30.0])
        assert _ptmeas(client, air, np.array([0.0, 0.0, 1.0])).numbers == [1006]
        assert client.send("ClearAllErrors()").errors == []
        assert client.send("EndSession()").errors == []
        client.close()
    transcript.close()
    _, records = read_transcript(tmp_path / "t.jsonl")
    probes = [r for r in records if r["kind"] == "point" and "error" not in r]
    assert len(probes) == len(normals) and all("true_tip_mm" not in r for r in probes)
    heights = np.array([r["heights_mm"] for r in probes])
    u_tip = np.array([r["tip_uncertainty_mm"] for r in probes])
    spread = _calibration_spread(model, heights, normals)
    errors = np.linalg.norm(np.array(points) - sphere, axis=1) - SPHERE_DIAMETER / 2
    # each point's error against the sphere within 4 standard deviations of the calibration and the readings
    # (the simulated stages stop at the contact microstep: no trigger lag to add)
    bound = 4.0 * np.hypot(spread, u_tip)
    assert np.all(np.abs(errors) <= bound), (errors, bound)
    assert np.all(spread > 0) and np.all(u_tip > 0)
    back = measured_points(records)
    np.testing.assert_allclose(back.points, np.array(points), atol=2e-6)  # the reported six-decimal numbers
    moves = [r for r in records if r["kind"] == "move"]
    assert moves[0]["homing"] is True and all(len(r["counts_usteps"]) == 3 for r in moves)


def test_the_point_is_the_calibrated_kinematics_of_the_readings_at_trigger(model: Any, center: np.ndarray,
                                                                           tmp_path: Path) -> None:
    """Virtual ports: the reported point is the calibrated forward kinematics of the readings latched at the
    trigger, less the calibrated radius along the direction; its Q flag is the model's verdict on that pose; the
    simulator's true tip at those counts touches the sphere (one ball radius from it)."""
    from pcmm_geo.ippdme.machine import reported_tip, tip_uncertainties
    from pcmm_geo.ippdme.transcript import Transcript, read_transcript

    sphere = center + SPHERE_OFFSET
    transcript = Transcript(tmp_path / "t.jsonl", {})
    with driver_server(model, transport="virtual", transcript=transcript) as (server, rig, machine):
        client = IppClient(server.port)
        client.send("StartSession()")
        assert client.send("Home()").errors == []
        rig.place_gauge_block(block=_SphereClearance(sphere, SPHERE_DIAMETER))
        client.send("OnPtMeasReport(X(), Y(), Z(), Q(), ER())")
        n = np.array([0.0, 0.6, 0.8])
        reply = _ptmeas(client, sphere + SPHERE_DIAMETER / 2 * n, n)
        assert reply.errors == []
        client.send("EndSession()")
        client.close()
        served = machine.model
        true_machine = rig.cmm.machine
    transcript.close()
    record = next(r for r in read_transcript(tmp_path / "t.jsonl")[1] if r["kind"] == "point")
    lasers, heights = np.array([record["lasers_mm"]]), np.array([record["heights_mm"]])
    tip = reported_tip(served, lasers, heights)
    v = reply.values()
    np.testing.assert_allclose([v["X"][0], v["Y"][0], v["Z"][0]], tip[0] - served.tip_radius * n, atol=2e-6)
    assert v["ER"][0] == pytest.approx(served.tip_radius, abs=1e-6)
    _, alone = tip_uncertainties(served, lasers, heights, tip)
    assert v["Q"][0] == (50 if alone[0] > machine.max_tip_uncertainty else 0)
    assert record["poorly_resolved"] == (alone[0] > machine.max_tip_uncertainty)
    # the heights are whole counts; the true machine's tip at them touches the sphere
    counts = machine.counts_of(heights[0])
    np.testing.assert_allclose(machine.heights_of(counts), heights[0], rtol=0, atol=1e-9)
    true_tip = true_machine.forward(heights=heights, lasers_hint=true_machine.reference_lasers,
                                    check_limits=False).tip[0]
    assert abs(np.linalg.norm(true_tip - sphere) - (SPHERE_DIAMETER / 2 + 1.0)) < 2e-3  # a microstep's tilt


def test_transient_device_faults_are_retried_and_the_point_is_unchanged(model: Any, center: np.ndarray) -> None:
    """Garbled, dropped, late and busy replies (seeded, virtual ports) are retried: the same point to a count step."""
    sphere = center + SPHERE_OFFSET
    n = np.array([0.0, 0.0, 1.0])
    points = []
    for rate in (0.0, 0.03):
        with driver_server(model, transport="virtual", fault_rate=rate, seed=5) as (server, rig, _):
            client = IppClient(server.port)
            client.send("StartSession()")
            assert client.send("Home()").errors == []
            rig.place_gauge_block(block=_SphereClearance(sphere, SPHERE_DIAMETER))
            reply = _ptmeas(client, sphere + SPHERE_DIAMETER / 2 * n, n)
            assert reply.errors == [], reply.lines
            v = reply.values()
            points.append([v["X"][0], v["Y"][0], v["Z"][0]])
            client.send("EndSession()")
            client.close()
            injected = sum(rig.injected_faults.values())
    assert injected >= 5  # the faulty run met faults of several devices
    # the same contact: the laser counts (ILD1302 12.5 um) can change the weighted solution by a few um at most
    assert np.linalg.norm(np.subtract(points[0], points[1])) < 0.005


def test_out_of_volume_goto_moves_nothing_and_collision_stops(model: Any, center: np.ndarray) -> None:
    sphere = center + SPHERE_OFFSET
    with driver_server(model, transport="virtual") as (server, rig, _):
        client = IppClient(server.port)
        client.send("StartSession()")
        client.send("Home()")
        before = dict(rig.zaber.positions)
        far = client.send("GoTo(X(0), Y(0), Z(900))")
        assert far.numbers == [2500] and rig.zaber.positions == before  # refused before anything moved
        client.send("ClearAllErrors()")
        rig.place_gauge_block(block=_SphereClearance(sphere, SPHERE_DIAMETER))
        start = sphere + np.array([0.0, 0.0, 25.0])
        client.send(f"GoTo(X({num(start[0])}), Y({num(start[1])}), Z({num(start[2])}))")
        through = sphere - np.array([0.0, 0.0, 25.0])
        hit = client.send(f"GoTo(X({num(through[0])}), Y({num(through[1])}), Z({num(through[2])}))")
        assert hit.numbers == [2504]
        # stopped at the contact: the true tip one ball radius (1 mm) from the sphere, to a few microsteps
        assert abs(np.linalg.norm(rig.cmm.tip - sphere) - (SPHERE_DIAMETER / 2 + 1.0)) < 0.01
        assert client.send("ClearAllErrors()").errors == []
        back = client.send(f"GoTo(X({num(start[0])}), Y({num(start[1])}), Z({num(start[2])}))")
        assert back.errors == []  # moving away from a touching pose is free
        client.send("EndSession()")
        client.close()


def test_a_port_dying_mid_move_answers_0503_and_the_server_stays_up(model: Any) -> None:
    with driver_server(model, transport="pty") as (server, rig, machine):
        client = IppClient(server.port)
        client.send("StartSession()")
        assert client.send("Home()").errors == []
        moves = {"count": 0}
        original = rig.cmm.move

        def failing(device: int, start: int, target: int) -> int:
            moves["count"] += 1
            if moves["count"] == 4:  # the cable is pulled during the second step of the move
                rig.zaber.disconnect_requested = True
            return original(device, start, target)

        rig.zaber.mover = failing
        target = machine.home_position - [0.0, 0.0, 30.0]
        reply = client.send(f"GoTo(X({num(target[0])}), Y({num(target[1])}), Z({num(target[2])}))")
        assert reply.numbers == [503] and reply.errors[0][0] == 9
        # the server answers; the machine no longer knows where it is, and says so
        assert client.send("GetErrStatusE()", event=True).data == ["ErrStatus(1)"]
        assert client.send("ClearAllErrors()").errors == []
        assert client.send("IsHomed()").data == ["IsHomed(0)"]
        assert client.send("GoTo(X(0))").numbers == [508]
        client.send("ClearAllErrors()")
        assert client.send("Home()").numbers == [503]  # the link is still dead
        client.send("ClearAllErrors()")
        assert client.send("EndSession()").errors == []
        client.close()
        again = _reconnect(server.port)  # a new client is served
        assert again.send("GetDMEVersion()").data == ['DMEVersion("1.4.3")']
        again.close()


def test_device_failures_map_to_the_spec_errors(model: Any) -> None:
    from pcmm_geo.ippdme.drivers import DriverMachine, StepSettings

    class _Motors:
        microstep_mm = 0.49609375e-3

    class _Devices:
        motors = _Motors()

    machine = DriverMachine(model, _Devices())
    machine.homed = True
    assert machine._refusal(DeviceError("zaber device 2", "move absolute: target out of range", 20)).number == 2500
    assert machine.homed
    assert machine._refusal(DeviceError("zaber device 1", "busy", 255)).number == 2502
    assert machine._refusal(DeviceError("laser_b", "no object detected", 16370)).number == 2503
    assert machine._refusal(DeviceError("zaber device 1", "cannot home", 1), homing=True).number == 1005
    assert machine.homed is False
    machine.homed = True
    assert machine._refusal(DeviceTimeoutError("probe", 0.5)).number == 503 and machine.homed is False
    assert machine._refusal(DeviceError("zaber", "port disconnected or failed: EIO")).number == 503
    # counts and heights: the reference count is the reference height; one count is one microstep
    reference = np.asarray(model.machine.reference_heights)
    np.testing.assert_array_equal(machine.counts_of(reference), [247_500] * 3)
    np.testing.assert_allclose(machine.heights_of([247_501, 247_500, 0]) - reference,
                               [0.49609375e-3, 0.0, -247_500 * 0.49609375e-3], rtol=0, atol=1e-9)
    with pytest.raises(InvalidInputError, match="fine_step_mm"):
        StepSettings(fine_step_mm=0.5)
    with pytest.raises(InvalidInputError, match="move_step_mm"):
        StepSettings(move_step_mm=0.0)


def test_abort_stops_a_driver_move_between_steps(model: Any) -> None:
    with driver_server(model, transport="pty") as (server, rig, machine):
        client = IppClient(server.port)
        client.send("StartSession()")
        client.send("Home()")
        slow = threading.Event()
        original = rig.cmm.move

        def held(device: int, start: int, target: int) -> int:
            slow.wait(0.02)  # 20 ms per stage move: the 60 mm move takes ~0.7 s
            return original(device, start, target)

        rig.zaber.mover = held
        target = machine.home_position - [0.0, 0.0, 60.0]
        daemon = client.send("OnMoveReportE(Time(0.1), X(), Y(), Z())", event=True)
        assert daemon.errors == []
        report_tag = daemon.lines[0].split()[0]
        client.raw(f"00100 GoTo(X({num(target[0])}), Y({num(target[1])}), Z({num(target[2])}))\r\n".encode())
        assert client.readline() == "00100 &"
        time.sleep(0.2)
        abort = client.send("AbortE()", event=True)
        assert abort.complete
        goto = [line for line in client.other if line.startswith("00100 ")]
        assert goto == ['00100 ! Error(2, 0006, "GoTo", "Transaction aborted (Use ClearAllErrors to Continue)")',
                        "00100 %"]
        stopped = machine.position.copy()
        reports = [line for line in client.other if line.startswith(report_tag + " # ")]
        assert reports, client.other  # the daemon reported the stepped move's position while it ran
        z = [float(line.split("Z(")[1].rstrip(")")) for line in reports]
        assert all(target[2] - 1e-6 <= value <= machine.home_position[2] + 1e-6 for value in z)
        assert 1.0 < np.linalg.norm(stopped - machine.home_position) < 59.0  # stopped on the way
        np.testing.assert_allclose(rig.cmm.tip, stopped, atol=0.01)  # where the stages are (to calibration)
        assert client.send("ClearAllErrors()").errors == []
        assert client.send("IsHomed()").data == ["IsHomed(1)"]
        # a client that vanishes mid-move: the move stops after its step, the next client finds the state consistent
        client.raw(f"00200 GoTo(X({num(target[0])}), Y({num(target[1])}), Z({num(target[2])}))\r\n".encode())
        time.sleep(0.2)
        client.close()
        again = _reconnect(server.port)
        assert again.send("IsHomed()").data == ["IsHomed(1)"]
        got = again.send("Get(X(), Y(), Z())").values()  # waits for the device lock: the stopped move's step is done
        np.testing.assert_allclose(rig.cmm.tip, machine.position, atol=0.01)
        np.testing.assert_allclose([got["X"][0], got["Y"][0], got["Z"][0]], rig.cmm.tip, atol=0.01)
        assert np.linalg.norm(machine.position - target) > 1.0  # it did not finish the move
        home = machine.home_position
        assert again.send(f"GoTo(X({num(home[0])}), Y({num(home[1])}), Z({num(home[2])}))").errors == []
        assert [rig.zaber.positions[d] for d in (1, 2, 3)] == machine.counts_of(
            model.machine.reference_heights + 40.0).tolist()
        again.send("EndSession()")
        again.close()


def test_pcmm_serve_on_ports(tmp_path: Path, calibration_file: Path) -> None:
    """``pcmm serve --port-zaber ...`` (pcmm acquire's option names) serves the devices of a pty rig, on the
    machine of a calibration file."""
    from pcmm_geo.acquisition.simulators.cmm import SimulatedMicroCMM, SimulatedRig
    from pcmm_geo.demo import DemoSettings, true_machine

    with SimulatedRig(SimulatedMicroCMM(machine=true_machine(DemoSettings())), transport="pty") as rig:
        args = [sys.executable, "-m", "pcmm_geo", "serve", "--port", "0", "--duration-s", "20", "--json",
                "--transcript", str(tmp_path / "t.jsonl"), "--timeout", "0.2", "--move-step-mm", "5",
                "--port-zaber", rig.ports["zaber"], "--port-laser-a", rig.ports["laser_a"],
                "--port-laser-b", rig.ports["laser_b"], "--port-laser-c", rig.ports["laser_c"],
                "--port-probe", rig.ports["probe"], "--calibration", str(calibration_file)]
        process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            line = process.stderr.readline()
            assert "I++ DME server on 127.0.0.1:" in line, line
            client = IppClient(int(line.rsplit(":", 1)[1].split()[0]))
            client.send("StartSession()")
            assert client.send("Home()").errors == []
            assert client.send("IsHomed()").data == ["IsHomed(1)"]
            assert client.send("EndSession()").errors == []
            client.close()
            assert [rig.zaber.positions[d] for d in (1, 2, 3)] == [328_130] * 3  # reference + 40 mm
        finally:
            process.terminate()
            process.communicate(timeout=30)
    header = json.loads((tmp_path / "t.jsonl").read_text().splitlines()[0])
    assert header["settings"]["backend"]["backend"] == "drivers"
    assert header["settings"]["ports"]["zaber"] == rig.ports["zaber"]
    assert header["settings"]["calibration"].startswith(str(calibration_file))
