"""Datum feature modifiers MMB / LMB: the part's mobility in its DRF, and position as the best over it.

ASME Y14.5-2018 7.11.6-7.11.8 (datum features referenced at MMB / LMB), 7.17 ("datum shift"); ISO 2692:2014
(the maximum / least material requirement applied to a datum feature, ``Ⓜ`` / ``Ⓛ`` after the datum letter):
a datum feature of size referenced at MMB is simulated by a boundary of fixed size (its MMB: the maximum
material size by default) located and oriented at the datum's nominal in the DRF of the higher datums.  The
part may then move relative to the DRF as long as that boundary stays within the datum feature's actual
envelope -- the gap between the two is the datum mobility ("datum shift"); the toleranced features are
evaluated at the best placement in it.

Supported here: a plane primary (referenced RMB; a plane has no size) and secondary / tertiary datum
features that are cylinders (holes or pins) with their axes nominally along the primary's direction.
The mobility is then a rigid motion of the part in the plane perpendicular to the primary: a translation
``t`` and a rotation ``theta`` about the primary direction through the DRF's origin,
``q' = R(theta) q + t`` in DRF coordinates.  Each datum after the primary restricts it:

- at MMB / LMB (a cylinder): its envelope's centre moved by the motion stays within ``gap`` of the nominal
  axis, ``|P(R m + t - c)| <= gap`` (``P`` the projection across the primary direction).  The envelope is
  the one the boundary bears on, constrained parallel to the primary (exact, 2-D): MMB -- the actual mating
  envelope (hole: maximum inscribed, pin: minimum circumscribed); LMB -- the actual minimum material
  envelope (hole: minimum circumscribed, pin: maximum inscribed).  ``gap`` is the radial clearance between
  the boundary and that envelope; a negative one means the part does not fit its boundary (the frame FAILs);
- at RMB, what it constrained in the DRF stays constrained: a plane the translation along its normal and,
  if it gave the rotation, the rotation; a cylinder the translations it fixed, and if it gave the rotation
  (a tertiary axis), its centre stays on the nominal line from the secondary's nominal centre;
- degrees of freedom no datum constrains stay free.

The position value is ``min over the mobility of max_k w_k |P_k (q'_k - n_k)|`` (a minimax): convex when the
rotation is held (translations only: SLSQP on the second-order-cone epigraph with its KKT multipliers, scope
``"global"``); with a rotation in the mobility it is solved with the exact rotation, a local optimum (scope
``"local"``) whose proven lower bound is the value less the largest change any admissible motion can make.
"""

from __future__ import annotations

from dataclasses import field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record

__all__ = ["DatumBoundary", "MobilityCertificate", "MobilityDomain", "MobilityResult", "solve_mobility"]

FloatArray = NDArray[np.float64]


@record
class DatumBoundary:
    """A datum feature of size referenced at MMB or LMB.

    Attributes
    ----------
    label : str
    modifier : {"MMB", "LMB"}
    side : {"internal", "external"}
        A hole (internal) or a pin (external).
    boundary_diameter_mm : float
        The boundary's size (MMB: the maximum material size, LMB: the least material size, unless the plan
        gives ``boundary_diameter``), mm.
    envelope : {"mic", "mcc"}
        The actual envelope the boundary bears on (constrained parallel to the primary, exact).
    envelope_diameter_mm : float
    envelope_center : ndarray, shape (3,)
        The envelope's axis point in DRF coordinates (in the plane through the origin across the primary), mm.
    nominal_center : ndarray, shape (3,)
        The boundary's axis point (the datum's nominal) in the same plane, DRF coordinates, mm.
    gap_mm : float
        Radial clearance between boundary and envelope (negative: the feature violates its boundary), mm.
    """

    label: str
    modifier: str
    side: str
    boundary_diameter_mm: float
    envelope: str
    envelope_diameter_mm: float
    envelope_center: FloatArray
    nominal_center: FloatArray
    gap_mm: float

    def to_dict(self) -> dict[str, object]:
        """JSON-ready (mm)."""
        return {"label": self.label, "modifier": self.modifier, "side": self.side,
                "boundary_diameter_mm": self.boundary_diameter_mm, "envelope": self.envelope,
                "envelope_diameter_mm": self.envelope_diameter_mm, "envelope_center_mm": self.envelope_center.tolist(),
                "nominal_center_mm": self.nominal_center.tolist(), "gap_mm": self.gap_mm}


@record
class MobilityDomain:
    """The motions ``q' = R(theta) q + t`` (DRF coordinates) the datums allow.

    Attributes
    ----------
    axis : ndarray, shape (3,)
        The primary's direction in the DRF (the rotation axis; ``t`` is perpendicular to it).
    boundaries : tuple of DatumBoundary
    held : tuple of (ndarray, ndarray)
        ``(c, e)``: ``e . (R c + t - c) = 0`` -- what an RMB datum holds: a plane's point along its normal, an
        axis's centre along the two directions across it, a tertiary axis's centre across its nominal line.
    rotation : {"free", "mobile", "held"}
        Free (no datum constrains it), mobile (only MMB / LMB datums do), or held (an RMB plane gives it).
    """

    axis: FloatArray
    boundaries: tuple[DatumBoundary, ...]
    held: tuple[tuple[FloatArray, FloatArray], ...] = ()
    rotation: str = "held"


@record
class MobilityCertificate:
    """KKT evidence of the best placement.

    ``sum(target_multipliers) = 1``; with ``g_k`` the gradient of ``w_k |P_k r_k|`` and ``h_j`` that of
    ``|P s_j|`` (``s_j`` the moved envelope centre minus the nominal) with respect to the motion's free
    parameters (translation across the held directions, and the rotation unless held),
    ``sum(mu_k g_k) + sum(nu_j h_j)`` vanishes up to ``kkt_residual``.

    Attributes
    ----------
    targets : ndarray of int
        Indices of the targets at the value.
    target_multipliers : ndarray
    boundaries : ndarray of int
        Indices of the boundaries touched (``|P s_j| = gap_j``).
    boundary_multipliers : ndarray
    kkt_residual : float
    scope : {"global", "local"}
    """

    targets: NDArray[np.int64]
    target_multipliers: FloatArray
    boundaries: NDArray[np.int64]
    boundary_multipliers: FloatArray
    kkt_residual: float
    scope: str


@record
class MobilityResult:
    """The best placement within the mobility.

    Attributes
    ----------
    value : float
        ``max_k w_k |P_k r_k|`` at the placement.
    bound : float
        Proven lower bound over the whole mobility (= ``value`` when global; NaN when none).
    shift_mm : ndarray, shape (3,)
        The translation ``t`` of the part in the DRF (the datum shift used), mm.
    rotation_rad : float
        Its rotation about the primary direction, rad.
    deviations : ndarray, shape (K, 3)
        ``P_k (q'_k - n_k)`` at the placement, mm (unweighted).
    feasible : bool
        False when no motion satisfies every boundary (the part does not fit them).
    certificate : MobilityCertificate
    """

    value: float
    bound: float
    shift_mm: FloatArray
    rotation_rad: float
    deviations: FloatArray
    feasible: bool
    certificate: MobilityCertificate = field(repr=False)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready: the datum shift used, the rotation, the scope and the certificate."""
        c = self.certificate
        return {"datum_shift_mm": self.shift_mm.tolist(), "datum_rotation_rad": self.rotation_rad,
                "scope": c.scope, "feasible": self.feasible,
                "certificate": {"targets": c.targets.tolist(), "target_multipliers": c.target_multipliers.tolist(),
                                "boundaries": c.boundaries.tolist(),
                                "boundary_multipliers": c.boundary_multipliers.tolist(),
                                "kkt_residual": c.kkt_residual}}


def _across(axis: FloatArray) -> tuple[FloatArray, FloatArray]:
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    e1 = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def _rot(axis: FloatArray, theta: float) -> FloatArray:
    kx = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(theta) * kx + (1 - np.cos(theta)) * kx @ kx


def solve_mobility(targets: FloatArray, nominals: FloatArray, projections: FloatArray, weights: FloatArray,
                   domain: MobilityDomain) -> MobilityResult:
    """``min over the mobility of max_k w_k |P_k (R q_k + t - n_k)|``.

    Parameters
    ----------
    targets, nominals : ndarray, shape (K, 3)
        What the zones hold (axis ends, centres) and their true positions, DRF coordinates, mm.
    projections : ndarray, shape (K, 3, 3)
        Each zone's projection onto its cross-section.
    weights : ndarray, shape (K,)
        ``2 / allowed`` for a pattern's ratio, 2 for a single position's value.
    domain : MobilityDomain

    Returns
    -------
    MobilityResult
    """
    from scipy.optimize import minimize

    q = np.asarray(targets, dtype=float)
    n = np.asarray(nominals, dtype=float)
    proj = np.asarray(projections, dtype=float)
    w = np.asarray(weights, dtype=float)
    axis = np.asarray(domain.axis, dtype=float) / np.linalg.norm(domain.axis)
    e1, e2 = _across(axis)
    span = np.array([e1, e2])
    lever = max(1.0, float(np.abs(q).max()), *(float(np.linalg.norm(b.envelope_center)) for b in domain.boundaries))
    rotating = domain.rotation != "held"

    def motion(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        return _rot(axis, x[2] / lever if rotating else 0.0), x[:2] @ span

    def residuals(x: FloatArray) -> FloatArray:
        r, t = motion(x)
        return np.einsum("kij,kj->ki", proj, q @ r.T + t - n)

    def objective_terms(x: FloatArray) -> FloatArray:
        return w * np.linalg.norm(residuals(x), axis=1)

    def boundary_terms(x: FloatArray) -> FloatArray:
        r, t = motion(x)
        out = []
        for b in domain.boundaries:
            s = r @ b.envelope_center + t - b.nominal_center
            out.append(float(np.linalg.norm(s - (s @ axis) * axis)))
        return np.array(out)

    sigma = max(float(objective_terms(np.zeros(4)).max()), 1e-6)
    cons = [{"type": "ineq", "fun": lambda x: (x[3] * sigma) ** 2 - objective_terms(x) ** 2}]
    gaps = np.array([b.gap_mm for b in domain.boundaries])
    if len(gaps):
        cons.append({"type": "ineq", "fun": lambda x: (np.maximum(gaps, 0.0) ** 2 - boundary_terms(x) ** 2) * 1e4})
    eqs = []
    for c, e in domain.held:
        eqs.append(_held_equation(motion, np.asarray(c, dtype=float), np.asarray(e, dtype=float)))
    if eqs:
        cons.append({"type": "eq", "fun": lambda x: np.array([f(x) for f in eqs])})
    x0 = np.r_[0.0, 0.0, 0.0, 1.0]
    bounds = [(None, None), (None, None), (None, None) if rotating else (0.0, 0.0), (0.0, None)]
    if len(gaps):  # start from a motion that fits every boundary (the least largest excess over them)
        fit_cons = [{"type": "ineq", "fun": lambda x: x[3] - (boundary_terms(x) - gaps) * 1e3}]
        fit_cons += [c for c in cons if c["type"] == "eq"]
        fit = minimize(lambda x: x[3], np.r_[0.0, 0.0, 0.0, float((boundary_terms(x0) - gaps).max()) * 1e3],
                       jac=lambda x: np.r_[0.0, 0.0, 0.0, 1.0], method="SLSQP",
                       bounds=[*bounds[:3], (None, None)], constraints=fit_cons,
                       options={"ftol": 1e-16, "maxiter": 500})
        x0 = np.r_[fit.x[:3], float(objective_terms(fit.x).max()) / sigma]
    res = minimize(lambda x: x[3], x0, jac=lambda x: np.r_[0.0, 0.0, 0.0, 1.0], method="SLSQP", bounds=bounds,
                   constraints=cons, options={"ftol": 1e-16, "maxiter": 500})
    x = np.asarray(res.x, dtype=float)
    x[2] = x[2] if rotating else 0.0
    def gradients(x: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Analytic gradients (rows) of the targets' terms, the boundaries' |P s| and the held equalities with
        respect to the motion parameters (t along e1, e2; the rotation in mm at the lever)."""
        r, t = motion(x)
        res = residuals(x)
        spin = np.cross(axis, q @ r.T) / lever
        u = np.einsum("kji,kj->ki", proj, res) / np.maximum(np.linalg.norm(res, axis=1), 1e-300)[:, None]
        g_t = w[:, None] * np.c_[u @ e1, u @ e2, np.einsum("ki,ki->k", u, spin)]
        g_b = []
        for b in domain.boundaries:
            moved = r @ b.envelope_center
            s = moved + t - b.nominal_center
            s = s - (s @ axis) * axis
            us = s / max(float(np.linalg.norm(s)), 1e-300)
            g_b.append([us @ e1, us @ e2, us @ np.cross(axis, moved) / lever])
        g_e = [[e @ e1, e @ e2, e @ np.cross(axis, r @ np.asarray(c, float)) / lever] for c, e in domain.held]
        return g_t, np.array(g_b).reshape(-1, 3), np.array(g_e, dtype=float).reshape(-1, 3)

    x = _zero_candidate(x, residuals, w, eqs, boundary_terms, gaps, objective_terms, rotating)
    x = _polish(x, objective_terms, boundary_terms, eqs, gaps, rotating, gradients)
    terms = objective_terms(x)
    value = float(terms.max())
    touched = boundary_terms(x) if len(gaps) else np.zeros(0)
    scale_tol = 1e-7 * max(1.0, float(np.max(gaps, initial=0.0)))
    feasible = bool(np.all(gaps >= -1e-12) and np.all(touched <= np.maximum(gaps, 0.0) + scale_tol)
                    and all(abs(f(x)) <= 1e-9 for f in eqs))
    r, t = motion(x)
    cert = _certificate(x, value, terms, touched, gaps, residuals(x), q, proj, w, domain, span, axis, lever, r)
    if feasible:
        scope = "global" if not rotating and cert.kkt_residual <= 1e-7 else "local"
    else:  # no motion fits: proven by convexity (translations only) or by the boundaries' distances
        scope = "global" if (not rotating and float((touched - gaps).max()) > 1e-6) or _apart(domain) else "local"
    cert = MobilityCertificate(cert.targets, cert.target_multipliers, cert.boundaries, cert.boundary_multipliers,
                               cert.kkt_residual, scope)
    if scope == "global" and len(cert.targets):
        # convexity: for any admissible t, max_k f_k(t) >= sum mu_k f_k(t*) - |residual| |t - t*| - sum nu_j slack_j
        # (|t - t*| <= 2 gap: both lie in a boundary's disk; slack_j = gap_j - |s_j(t*)| of a touched boundary)
        slack = np.maximum(gaps[cert.boundaries] - touched[cert.boundaries], 0.0) if len(cert.boundaries) else 0.0
        lagrangian = float(cert.target_multipliers @ terms[cert.targets]) - float(np.sum(
            cert.boundary_multipliers * slack))
        bound = max(0.0, min(value, lagrangian) - cert.kkt_residual * 2.0 * float(np.max(np.abs(gaps), initial=0.0)))
    elif scope == "global":
        bound = value  # zero: its own lower bound
    else:
        bound = _lipschitz_bound(value, q, w, domain, axis)
    return MobilityResult(value, bound if feasible else float("nan"), t, float(x[2] / lever) if rotating else 0.0,
                          residuals(x), feasible, cert)


def _gradient(fun: Any, p: FloatArray, h: float = 1e-7) -> FloatArray:
    """Central differences of a vector function, shape (len(fun(p)), len(p))."""
    cols = []
    for i in range(len(p)):
        step = np.zeros(len(p))
        step[i] = h
        cols.append((np.atleast_1d(fun(p + step)) - np.atleast_1d(fun(p - step))) / (2 * h))
    return np.array(cols).T


def _apart(domain: MobilityDomain) -> bool:
    """True when two boundaries' envelope centres are farther from (or nearer to) each other than their
    nominal centres by more than both clearances: no rigid motion changes that distance."""
    axis = np.asarray(domain.axis, dtype=float)
    b = domain.boundaries
    for i in range(len(b)):
        for j in range(i + 1, len(b)):
            actual = np.cross(axis, b[j].envelope_center - b[i].envelope_center)
            nominal = np.cross(axis, b[j].nominal_center - b[i].nominal_center)
            if abs(np.linalg.norm(actual) - np.linalg.norm(nominal)) > max(b[i].gap_mm, 0) + max(b[j].gap_mm, 0) + 1e-9:
                return True
    return False


def _held_equation(motion: Any, c: FloatArray, e: FloatArray) -> Any:
    """``e . (R c + t - c)`` as a function of the motion's parameters."""
    def equation(x: FloatArray) -> float:
        r, t = motion(x)
        return float(e @ (r @ c + t - c))

    return equation


def _zero_candidate(x: FloatArray, residuals: Any, w: FloatArray, eqs: list[Any], boundary_terms: Any,
                    gaps: FloatArray, objective_terms: Any, rotating: bool) -> FloatArray:
    """The least-squares placement (Gauss-Newton, the held equalities weighted heavily) when it is admissible
    and better: a pattern the mobility centres exactly has value 0, where the minimax is not smooth."""
    from scipy.optimize import least_squares

    m = 3 if rotating else 2

    def stacked(p: FloatArray) -> FloatArray:
        xx = x.copy()
        xx[:m] = p
        e = np.array([g(xx) for g in eqs]) if eqs else np.zeros(0)
        return np.r_[(residuals(xx) * w[:, None]).reshape(-1), 1e3 * e]

    fit = least_squares(stacked, x[:m], xtol=1e-15, ftol=1e-15, gtol=1e-15, method="lm")
    candidate = x.copy()
    candidate[:m] = fit.x
    admissible = (not len(gaps) or np.all(boundary_terms(candidate) <= np.maximum(gaps, 0.0))) and all(
        abs(g(candidate)) <= 1e-12 for g in eqs)
    better = float(objective_terms(candidate).max()) < float(objective_terms(x).max())
    return candidate if admissible and better else x


def _polish(x: FloatArray, objective_terms: Any, boundary_terms: Any, eqs: list[Any], gaps: FloatArray,
            rotating: bool, gradients: Any) -> FloatArray:
    """Newton on the KKT system of the active set found by SLSQP (its point is only as exact as the square
    root of its tolerance where the value is flat); kept only when the value does not rise and it stays
    feasible."""
    m = 3 if rotating else 2
    terms = objective_terms(x)
    value = float(terms.max())
    if value <= 0 or np.any(np.abs(gaps) <= 1e-12):
        return x
    active = np.flatnonzero(terms >= value * (1 - 1e-6))
    g_t = gradients(x)[0][:, :m]
    kept: list[int] = []
    for k in active:  # identical terms (a straight axis's two ends) would make the system singular
        if all(np.linalg.norm(g_t[k] - g_t[j]) > 1e-9 * max(1.0, float(np.linalg.norm(g_t[k]))) for j in kept):
            kept.append(int(k))
    active = np.array(kept, dtype=np.int64)
    touched = boundary_terms(x) if len(gaps) else np.zeros(0)
    bactive = np.flatnonzero(touched >= gaps - 1e-6 * np.maximum(gaps, 1e-9)) if len(gaps) else np.zeros(0, int)

    def full(p: FloatArray) -> FloatArray:
        out = x.copy()
        out[:m] = p
        return out

    def parts(p: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        xx = full(p)
        f = objective_terms(xx)[active]
        hb = boundary_terms(xx)[bactive] - gaps[bactive] if len(bactive) else np.zeros(0)
        e = np.array([g(xx) for g in eqs]) if eqs else np.zeros(0)
        return f, hb, e

    na, nd, ne = len(active), len(bactive), len(eqs)

    def kkt(z: FloatArray) -> FloatArray:
        p, tau = z[:m], z[m]
        mu, nu, lam = z[m + 1:m + 1 + na], z[m + 1 + na:m + 1 + na + nd], z[m + 1 + na + nd:]
        g_t, g_b, g_e = gradients(full(p))
        jac = np.vstack([g_t[active], g_b[bactive], g_e])[:, :m]
        stationarity = jac.T @ np.r_[mu, nu, lam]
        f, hb, e = parts(p)
        return np.r_[stationarity, 1.0 - mu.sum(), f - tau, hb, e]

    z = np.r_[x[:m], value, np.full(na, 1.0 / na), np.zeros(nd), np.zeros(ne)]
    # multipliers from a least-squares start
    g_t, g_b, g_e = gradients(x)
    jac0 = np.vstack([g_t[active], g_b[bactive], g_e])[:, :m]
    a0 = np.vstack([jac0.T, np.r_[np.ones(na), np.zeros(nd + ne)]])
    z[m + 1:] = np.linalg.lstsq(a0, np.r_[np.zeros(m), 1.0], rcond=None)[0]
    for _ in range(12):
        g = kkt(z)
        if np.linalg.norm(g) < 1e-15:
            break
        jz = _gradient(kkt, z, 1e-8)
        z = z - np.linalg.lstsq(jz, g, rcond=None)[0]
    candidate = full(z[:m])
    new_value = float(objective_terms(candidate).max())
    ok = new_value <= value + 1e-10 * max(1.0, value) and (
        not len(gaps) or np.all(boundary_terms(candidate) <= np.maximum(gaps, 0) + 1e-12)) and all(
        abs(g(candidate)) <= 1e-12 for g in eqs) and np.all(z[m + 1:m + 1 + na + nd] >= -1e-9)
    return candidate if ok else x


def _free_columns(span: FloatArray, rotating: bool) -> FloatArray:
    """Columns (3 + 1, m): the motion's parameters (the two translations across the axis, the rotation)."""
    cols = [np.r_[span[0], 0.0], np.r_[span[1], 0.0]] + ([np.r_[0.0, 0.0, 0.0, 1.0]] if rotating else [])
    return np.array(cols).T


def _certificate(x: FloatArray, value: float, terms: FloatArray, touched: FloatArray, gaps: FloatArray,
                 resid: FloatArray, q: FloatArray, proj: FloatArray, w: FloatArray, domain: MobilityDomain,
                 span: FloatArray, axis: FloatArray, lever: float, r: FloatArray) -> MobilityCertificate:
    """Active sets and non-negative multipliers (NNLS) of the stationarity in the free motion parameters."""
    from scipy.optimize import nnls

    rotating = domain.rotation != "held"
    tol = 1e-7 * max(value, 1e-9)
    active = np.flatnonzero(terms >= value - tol) if value > 0 else np.zeros(0, dtype=np.int64)
    bactive = np.flatnonzero(touched >= np.maximum(gaps, 0.0) - 1e-9) if len(gaps) else np.zeros(0, dtype=np.int64)
    cols = _free_columns(span, rotating)
    # what an RMB datum holds: those gradients (multipliers of either sign) are removed from the stationarity
    line_grads = []
    for c, e in domain.held:
        rc = r @ np.asarray(c, float)
        line_grads.append(np.r_[np.asarray(e, float), float(np.asarray(e, float) @ np.cross(axis, rc))])
    grads = []
    for k in active:
        u = proj[k].T @ resid[k] / max(float(np.linalg.norm(resid[k])), 1e-300)
        rq = r @ q[k]
        grads.append(w[k] * np.r_[u, float(u @ np.cross(axis, rq))])
    for j in bactive:
        b = domain.boundaries[j]
        s = r @ b.envelope_center + x[:2] @ span - b.nominal_center
        s = s - (s @ axis) * axis
        u = s / max(float(np.linalg.norm(s)), 1e-300)
        grads.append(np.r_[u, float(u @ np.cross(axis, r @ b.envelope_center))])
    m = cols.shape[1]
    if not grads or m == 0:
        return MobilityCertificate(active.astype(np.int64), np.full(len(active), 1.0 / max(len(active), 1)),
                                   bactive.astype(np.int64), np.zeros(len(bactive)), 0.0, "global")
    g = np.array(grads) @ cols  # (n_active, m)
    if line_grads:
        lg = np.array(line_grads) @ cols
        # project out the held lines' gradients (their multipliers are free in sign)
        u_, sv, _ = np.linalg.svd(lg.T, full_matrices=False)
        qmat = u_[:, sv > 1e-9 * max(1.0, float(sv.max()))]
        g = g - (g @ qmat) @ qmat.T
    rows = np.vstack([g.T, np.r_[np.ones(len(active)), np.zeros(len(bactive))]])
    mult, residual = nnls(rows, np.r_[np.zeros(m), 1.0])
    return MobilityCertificate(active.astype(np.int64), mult[:len(active)], bactive.astype(np.int64),
                               mult[len(active):], float(residual), "global")


def _lipschitz_bound(value: float, q: FloatArray, w: FloatArray, domain: MobilityDomain, axis: FloatArray) -> float:
    """A proven lower bound over the mobility: the value less the largest change of a weighted deviation between
    two admissible motions (NaN when a free rotation leaves it unbounded).

    Points whose travel is bounded: a boundary's envelope centre (``2 gap``), an axis held at RMB in both
    directions across it (0).  The rotation between two motions is bounded by two such points
    (``2 asin((T1 + T2) / (2 d))``); a deviation then changes by at most ``T + dtheta |q - anchor|``.
    """
    if domain.rotation == "free":
        return float("nan")
    anchors = [(b.envelope_center, 2.0 * max(b.gap_mm, 0.0)) for b in domain.boundaries]
    held: dict[tuple[float, ...], int] = {}
    for c, _ in domain.held:
        key = tuple(np.round(np.asarray(c, float), 12))
        held[key] = held.get(key, 0) + 1
    anchors += [(np.array(k), 0.0) for k, count in held.items() if count >= 2]
    if not anchors:
        return float("nan")
    anchors.sort(key=lambda a: a[1])
    anchor, travel = anchors[0]
    spin = 0.0
    if domain.rotation == "mobile":
        if len(anchors) < 2:
            return float("nan")
        other, travel2 = max(anchors[1:], key=lambda a: float(np.linalg.norm(np.cross(a[0] - anchor, axis))))
        arm = float(np.linalg.norm(np.cross(other - anchor, axis)))
        if arm <= 0 or (travel + travel2) >= 2 * arm:
            return float("nan")
        spin = 2.0 * float(np.arcsin((travel + travel2) / (2.0 * arm)))
    arms = np.linalg.norm(np.cross(q - anchor, axis), axis=1)
    return max(0.0, value - float(np.max(w * (travel + spin * arms))))
