"""An independent I++ client measures simulated artefacts; pcmm evaluates the points against the stated U.

The client (tests/ippdme/ipp_client.py) is written from the spec and shares no code with the
server.  The stated expanded uncertainty (k = 2) is the virtual micro-CMM's GUM result for the
same contacts (:class:`pcmm_geo.uncertainty.virtual_cmm.VirtualCMM`), with the height reading's
count step added to the encoder noise (:attr:`MachineModel.height_sigma`).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import running_server
from ipp_client import IppClient, num
from pcmm_runner import run_pcmm
from scipy import stats

from pcmm_geo.fit import fit_sphere
from pcmm_geo.ippdme.machine import MachineModel, SimulatedMachine
from pcmm_geo.ippdme.transcript import Transcript, measured_points, read_transcript, write_points_csv
from pcmm_geo.ippdme.workpieces import BoxWorkpiece, SphereWorkpiece
from pcmm_geo.uncertainty.tasks import MeasurementTask, gauge_block_central_lengths, sphere_task
from pcmm_geo.uncertainty.virtual_cmm import VirtualCMM

DIAMETER = 20.0
LENGTH = 50.0


def spiral(count: int) -> np.ndarray:
    """Outward normals of ``count`` probings on the upper hemisphere (a golden-angle spiral), client side."""
    k = np.arange(count)
    z = 1.0 - (k + 0.5) / count * 0.95
    ring = np.sqrt(1.0 - z * z)
    angle = k * np.pi * (3.0 - np.sqrt(5.0))
    return np.column_stack([ring * np.cos(angle), ring * np.sin(angle), z])


def stated_u(model, contacts: np.ndarray, normals: np.ndarray, evaluate, name: str) -> float:
    vcmm = VirtualCMM(model.machine, model.tip_radius, model.calibration_covariance,
                      laser_sigma=model.laser_sigma, encoder_sigma=model.height_sigma)
    task = MeasurementTask(name, name, 0.0, contacts, normals, evaluate)
    return float(vcmm.gum(task).expanded_uncertainty)


def probe(client: IppClient, point: np.ndarray, normal: np.ndarray, safe_z: float) -> np.ndarray:
    """Lift to ``safe_z``, go above the approach point, down to it, probe: the reported X, Y, Z."""
    approach = point + 4.0 * normal
    here = client.send("Get(X(), Y(), Z())").values()
    for target in ([here["X"][0], here["Y"][0], safe_z], [approach[0], approach[1], safe_z], approach):
        reply = client.send(f"GoTo(X({num(target[0])}), Y({num(target[1])}), Z({num(target[2])}))")
        assert reply.errors == [], reply.lines
    reply = client.send(f"PtMeas(X({num(point[0])}), Y({num(point[1])}), Z({num(point[2])}), "
                        f"IJK({num(normal[0])}, {num(normal[1])}, {num(normal[2])}))")
    assert reply.errors == [], reply.lines
    v = reply.values()
    return np.array([v["X"][0], v["Y"][0], v["Z"][0]])


#: a single run may lie outside U (5 %); |error| <= 1.5 U fails with probability 0.27 % for a correct U
SINGLE_RUN = 1.5


@pytest.mark.slow
def test_client_measures_a_sphere_and_pcmm_evaluates_the_replayed_points(model, center, tmp_path) -> None:
    normals = spiral(25)
    contacts = center + DIAMETER / 2 * normals
    u_sphere = stated_u(model, contacts, normals, sphere_task(DIAMETER, center).evaluate, "diameter")
    assert 0.0002 < u_sphere < 0.01  # micrometre-level, not a degenerate 0 nor a millimetre
    transcript = Transcript(tmp_path / "session.jsonl", {"test": "sphere"})
    with running_server(model, [SphereWorkpiece(center, DIAMETER)], seed=3, transcript=transcript) as server:
        c = IppClient(server.port)
        c.send("StartSession()")
        c.send("Home()")
        measured = np.array([probe(c, p, n, center[2] + 20.0) for p, n in zip(contacts, normals, strict=True)])
        c.send("EndSession()")
        c.close()
    transcript.close()
    error = 2 * fit_sphere(measured).radius - DIAMETER
    assert abs(error) <= SINGLE_RUN * u_sphere, (error, u_sphere)
    # the transcript replays to the same points, which pcmm's CLI evaluates
    _, records = read_transcript(tmp_path / "session.jsonl")
    moves = [r for r in records if r["kind"] == "move"]
    assert len(moves) >= 3 * 25 and all(0.0 < v < 200.0 for r in moves for v in r["lasers_mm"])  # laser range
    replayed = measured_points(records)
    np.testing.assert_allclose(replayed.points, measured, atol=2e-6)  # 6 decimals on the wire
    out = run_pcmm("serve", "--replay", tmp_path / "session.jsonl", "--points-out", tmp_path / "pts.csv", "--json")
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["points"] == 25
    fit = run_pcmm("fit", "sphere", tmp_path / "pts.csv", "--json")
    assert fit.returncode == 0, fit.stderr
    assert abs(json.loads(fit.stdout)["radius"] * 2 - DIAMETER - error) < 1e-5
    iso = run_pcmm("iso10360-5", tmp_path / "pts.csv", "--reference-diameter-mm", str(DIAMETER), "--json")
    assert iso.returncode in (0, 1), iso.stderr


#: (y, z) offsets of the 5 probings on each measuring face of the gauge block (mm), client side
OFFSETS = np.array([[0.0, 0.0], [12.0, 0.0], [-12.0, 0.0], [0.0, 3.0], [0.0, -3.0]])


def block_u(model, center) -> tuple[np.ndarray, np.ndarray, float]:
    nominal = np.vstack([center + np.column_stack([np.full(5, s * LENGTH / 2), OFFSETS]) for s in (-1.0, 1.0)])
    normals = np.repeat([[-1.0, 0, 0], [1.0, 0, 0]], 5, axis=0)
    u = stated_u(model, nominal, normals, lambda p: gauge_block_central_lengths(p[:, :5], p[:, 5:]), "length")
    return nominal, normals, u


@pytest.mark.slow
def test_client_measures_a_gauge_block(model, center) -> None:
    offsets = OFFSETS
    faces = []
    with running_server(model, [BoxWorkpiece(center, (LENGTH, 35.0, 9.0))], seed=4) as server:
        c = IppClient(server.port)
        c.send("StartSession()")
        c.send("Home()")
        for sign in (-1.0, 1.0):
            n = np.array([sign, 0.0, 0.0])
            pts = center + np.column_stack([np.full(5, sign * LENGTH / 2), offsets])
            faces.append(np.array([probe(c, p, n, center[2] + 15.0) for p in pts]))
        c.close()
    _, _, u_block = block_u(model, center)
    assert 0.0002 < u_block < 0.01
    length = float(gauge_block_central_lengths(faces[0][None], faces[1][None])[0])
    assert abs(length - LENGTH) <= SINGLE_RUN * u_block, (length - LENGTH, u_block)


def _coverage(errors: np.ndarray, u: float) -> None:
    """At least 26 of 30 within U: X ~ Bin(30, 0.95) falls below 26 with probability 0.016 (binomial margin);
    the errors' spread must match U/2 (chi-square, 30 degrees of freedom, 99.8 % two-sided): a U far too
    large fails too."""
    assert stats.binom.cdf(25, 30, 0.95) < 0.02  # the margin stated above
    inside = int(np.sum(np.abs(errors) <= u))
    assert inside >= 26, (inside, u, errors)
    ratio = float(np.sum((errors / (u / 2)) ** 2))
    low, high = stats.chi2.ppf([0.001, 0.999], len(errors))
    assert low < ratio < high, (ratio, low, high)


@pytest.mark.slow
def test_sphere_diameter_error_within_stated_u_in_95_percent_of_seeded_machines(model, center) -> None:
    """Same physics as the server's PtMeas (:meth:`SimulatedMachine.probe_many`), 30 true machines.

    The recorded run over 1000 machines is in docs/guide/ippdme.rst.
    """
    normals = spiral(25)
    contacts = center + DIAMETER / 2 * normals
    u = stated_u(model, contacts, normals, sphere_task(DIAMETER, center).evaluate, "diameter")
    errors = []
    for seed in range(30):
        machine = SimulatedMachine(model, [SphereWorkpiece(center, DIAMETER)], seed=1000 + seed)
        results = machine.probe_many(contacts, normals, 2.0, 4.0, diagnostics=False)
        errors.append(2 * fit_sphere(np.array([r.result.point for r in results])).radius - DIAMETER)
    _coverage(np.asarray(errors), u)


@pytest.mark.slow
def test_gauge_block_length_error_within_stated_u_in_95_percent_of_seeded_machines(model, center) -> None:
    nominal, normals, u = block_u(model, center)
    errors = []
    for seed in range(30):
        machine = SimulatedMachine(model, [BoxWorkpiece(center, (LENGTH, 35.0, 9.0))], seed=2000 + seed)
        points = np.array([r.result.point for r in machine.probe_many(nominal, normals, 2.0, 4.0, diagnostics=False)])
        errors.append(float(gauge_block_central_lengths(points[None, :5], points[None, 5:])[0]) - LENGTH)
    _coverage(np.asarray(errors), u)


@pytest.mark.parametrize("seed", [5])
def test_same_seed_same_points(model, center, seed) -> None:
    a = SimulatedMachine(model, [SphereWorkpiece(center, DIAMETER)], seed=seed)
    b = SimulatedMachine(model, [SphereWorkpiece(center, DIAMETER)], seed=seed)
    c = SimulatedMachine(model, [SphereWorkpiece(center, DIAMETER)], seed=seed + 1)
    n = spiral(5)
    pa = [r.result.point for r in a.probe_many(center + 10 * n, n, 2.0, 4.0)]
    pb = [r.result.point for r in b.probe_many(center + 10 * n, n, 2.0, 4.0)]
    pc = [r.result.point for r in c.probe_many(center + 10 * n, n, 2.0, 4.0)]
    np.testing.assert_allclose(pa, pb, atol=1e-12)
    assert np.max(np.abs(np.asarray(pa) - np.asarray(pc))) > 1e-6
    assert write_points_csv  # exported helper used by pcmm serve --replay


def test_laser_only_tip_uncertainty_is_in_millimetres(model: MachineModel) -> None:
    """The laser-only figure is laser_sigma times the root sum of 1/s^2 of the relative-height Jacobian: linear
    in laser_sigma (a square root of it, as once returned, would grow by sqrt(2) only), and equal to the spread
    of the least-squares relative heights under laser noise computed here from the forward kinematics."""
    import dataclasses

    from pcmm_geo.ippdme.machine import reported_tip, tip_uncertainties

    machine = model.machine
    heights = np.array([[5.0, -3.0, 2.0], [0.5, 0.0, -0.5]])
    lasers = np.asarray(machine.forward(heights=heights, lasers_hint=machine.reference_lasers,
                                        check_limits=False).lasers)
    tips = reported_tip(model, lasers, heights)
    _, alone = tip_uncertainties(model, lasers, heights, tips)
    _, doubled = tip_uncertainties(dataclasses.replace(model, laser_sigma=2 * model.laser_sigma), lasers, heights, tips)
    np.testing.assert_allclose(doubled, 2 * alone, rtol=1e-12)
    step = 1e-4
    for k in range(len(heights)):
        jac = np.empty((3, 3))
        for j in range(3):
            moved = heights[k].copy()
            moved[j] += step
            jac[:, j] = (np.asarray(machine.forward(heights=moved[None], lasers_hint=lasers[k][None],
                                                    check_limits=False).lasers)[0] - lasers[k]) / step
        relative = np.eye(3) - 1.0 / 3.0
        pinv = np.linalg.pinv(jac @ relative, rcond=1e-12)  # least-squares relative heights from the lasers
        expected = model.laser_sigma * np.sqrt(np.sum(pinv ** 2))
        assert alone[k] == pytest.approx(expected, rel=1e-3)
