"""Whether the data surround an axis: the domain of the maximum inscribed cylinder.

The maximum inscribed cylinder is the largest cylinder that the points *surround*: its
axis meets the interior of the convex hull of the points projected along it.  The
*depth* of an axis is the distance of its trace from the boundary of that projected hull
(positive inside); for an axis ``(X, d)`` it is ``min over unit u normal to d of
H(u) - u . X`` with ``H(u) = max_i u . P_i`` the support function of the points.  Over a
cell of axes (see :mod:`~pcmm_geo.fit.zone.axial.bounds`) the projected points move
relative to the axis by at most ``|h| sin(phi) + rho (1 - cos(phi)) + eps``, and the depth
is 1-Lipschitz in the points, which gives

* an upper bound: ``H(u) - u . X_c`` for unit ``u`` normal to ``d_c``, plus the largest
  move -- a cell with a negative upper bound holds no axis the data surround.  For hulls of
  few vertices ``u`` runs over the normals of the chords between the projected vertices and
  the directions from them to the trace, which hold the minimiser: the centre term is the
  depth itself and the bound tightens with the cell.  Larger hulls take ``H`` from a table of
  the support function on a cube-map grid of directions (``H(u) <= H(u_k) + R_max |u -
  u_k|``) at a few probe directions;
* a lower bound: the distance from the trace to the edges of the star polygon of a few
  outer points ordered by angle around it (that polygon lies in the hull), minus the
  largest move -- a cell with a positive lower bound holds only surrounded axes.

Where the largest empty cylinders approach the edge of the surrounded axes, the supremum
lies on that edge and the search cannot close its proof there (:class:`EdgeWatch`).
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.fit.zone.axial.bounds import cell_terms, directions, plane_basis

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.intp]

_SECTORS = 16
_GRID = 64  # support-table cells per cube-face side
_PROBES = 32  # directions normal to the axis tried for the upper bound
_GENERATORS = 24  # hulls of at most this many vertices: exact support values and centre depths
_CHUNK = 2_000_000  # cells x candidates x vertices per vectorised block
_TABLE_BLOCK = 16  # hull vertices per block of the support table (small blocks stay in cache)


def _cube_directions(grid: int) -> FloatArray:
    """Unit directions at the cell centres of a cube map, (6 grid^2, 3), face-major."""
    ticks = (np.arange(grid) + 0.5) / grid * 2.0 - 1.0
    s, t = np.meshgrid(ticks, ticks, indexing="ij")
    faces = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            face = np.empty((grid * grid, 3))
            face[:, axis] = sign
            face[:, (axis + 1) % 3] = s.ravel()
            face[:, (axis + 2) % 3] = t.ravel()
            faces.append(face)
    out = np.concatenate(faces)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def _cube_index(u: FloatArray, grid: int) -> IndexArray:
    """Index of the cube-map cell holding each unit direction ``u`` (..., 3)."""
    axis = np.argmax(np.abs(u), axis=-1)
    major = np.take_along_axis(u, axis[..., None], axis=-1)[..., 0]
    face = 2 * axis + (major < 0)
    s = np.take_along_axis(u, ((axis + 1) % 3)[..., None], axis=-1)[..., 0] / np.abs(major)
    t = np.take_along_axis(u, ((axis + 2) % 3)[..., None], axis=-1)[..., 0] / np.abs(major)
    i = np.clip(((s + 1.0) / 2.0 * grid).astype(int), 0, grid - 1)
    j = np.clip(((t + 1.0) / 2.0 * grid).astype(int), 0, grid - 1)
    return face * grid * grid + i * grid + j


class Surround:
    """Depth bounds of axis cells in the data of one chart frame (``points`` (N, 3)).

    ``hull``: indices of the convex-hull vertices (the support function is taken there).
    """

    def __init__(self, points: FloatArray, hull: IndexArray) -> None:
        self.points = points
        self.hull = hull
        self.extent = float(np.sqrt(np.einsum("ij,ij->i", points, points).max()))
        self._support: FloatArray | None = None
        # a direction lies in its cube cell; the cell's centre direction is within this chord of it
        corner = np.array([1.0, 1.0 / _GRID, 1.0 / _GRID])
        self.table_chord = float(np.linalg.norm(corner / np.linalg.norm(corner) - np.array([1.0, 0.0, 0.0])))
        angle = np.arctan2(points[:, 1], points[:, 0])
        radius = np.hypot(points[:, 0], points[:, 1])
        sector = np.minimum(((angle + np.pi) / (2 * np.pi) * _SECTORS).astype(int), _SECTORS - 1)
        outer = [int(np.flatnonzero(sector == s)[np.argmax(radius[sector == s])]) for s in range(_SECTORS)
                 if np.any(sector == s)]
        self.ring = np.array(outer, dtype=np.intp)
        self.vertices = points[hull] if len(hull) else points
        self.exact = len(self.vertices) <= _GENERATORS

    def support_upper(self, u: FloatArray) -> FloatArray:
        """Upper bound of the support function ``max_i u . P_i`` for unit ``u`` (..., 3)."""
        if self._support is None:  # by blocks of hull vertices: one (H, 6 grid^2) product is GBs for dense data
            grid, vertices = _cube_directions(_GRID).T, self.vertices
            self._support = np.full(grid.shape[1], -np.inf)
            for start in range(0, len(vertices), _TABLE_BLOCK):
                np.maximum(self._support, (vertices[start:start + _TABLE_BLOCK] @ grid).max(axis=0), out=self._support)
        return self._support[_cube_index(u, _GRID)] + self.extent * self.table_chord

    def cell_depth(self, center: FloatArray, half: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Upper and lower bounds (K,) of the depth of every axis of each cell (mm)."""
        ring = cell_terms(self.points[self.ring], center, half)
        axis = ring.axis
        first, second = plane_basis(axis)
        foot = np.zeros((len(center), 3))
        foot[:, :2] = center[:, :2]
        # how far the projected points can move relative to the axis over the cell
        along = np.einsum("kj,kj->k", foot, axis)
        if self.exact:  # few hull vertices: exact support values, no table
            heights = axis @ self.vertices.T
            height = np.maximum(heights.max(axis=1) - along, along - heights.min(axis=1))
        else:
            height = np.maximum(self.support_upper(axis) - along, self.support_upper(-axis) + along)
        reach = self.extent + np.linalg.norm(foot, axis=1)
        moved_all = height * ring.sin_phi + reach * ring.one_minus_cos + ring.eps + ring.slack
        if self.exact:
            upper = self.center_depth_upper(first, second, foot) + moved_all
        else:
            # min over probe directions u normal to d_c of H(u) - u . X_c (from the table: an
            # error that does not shrink with the cell)
            turn = np.linspace(0.0, 2 * np.pi, _PROBES, endpoint=False)
            probes = np.cos(turn)[None, :, None] * first[:, None, :] + np.sin(turn)[None, :, None] * second[:, None, :]
            upper = (self.support_upper(probes) - np.einsum("kpj,kj->kp", probes, foot)).min(axis=1) + moved_all
        # lower bound: star polygon of the outer ring around the centre trace
        rel = self.points[self.ring][None, :, :] - foot[:, None, :]
        u = np.einsum("ksj,kj->ks", rel, first)
        v = np.einsum("ksj,kj->ks", rel, second)
        order = np.argsort(np.arctan2(v, u), axis=1)
        u = np.take_along_axis(u, order, axis=1)
        v = np.take_along_axis(v, order, axis=1)
        u_next, v_next = np.roll(u, -1, axis=1), np.roll(v, -1, axis=1)
        cross = u * v_next - v * u_next
        edge = np.hypot(u_next - u, v_next - v)
        with np.errstate(divide="ignore", invalid="ignore"):
            distance = np.where(edge > 0, cross / edge, -np.inf)
        polygon = np.where((cross > 0).all(axis=1), distance.min(axis=1), -np.inf)
        moved = (np.abs(ring.height) * ring.sin_phi[:, None] + ring.rho * ring.one_minus_cos[:, None]).max(axis=1)
        lower = polygon - moved - ring.eps - ring.slack
        return upper, lower

    def center_depth_upper(self, first: FloatArray, second: FloatArray, foot: FloatArray) -> FloatArray:
        """Depths (K,) of the axes through ``foot`` normal to ``first``, ``second`` (hulls of few vertices).

        Every unit ``w`` normal to the axis gives ``depth <= max_i w . (P_i - X)`` over the hull
        vertices.  The candidates are the normals of the chords between the vertices (both
        ways) and the directions from the vertices to the trace: the nearest edge or vertex
        of the projected hull is among them, so the bound is the depth itself (to rounding).
        """
        vertices = self.vertices
        first_i, second_i = np.triu_indices(len(vertices), k=1)
        out = np.empty(len(foot))
        n_candidates = 2 * len(first_i) + len(vertices)
        step = max(1, _CHUNK // max(len(vertices) * n_candidates, 1))
        for start in range(0, len(foot), step):
            rows = slice(start, start + step)
            qx = first[rows] @ vertices.T - np.einsum("kj,kj->k", first[rows], foot[rows])[:, None]  # (K, H)
            qy = second[rows] @ vertices.T - np.einsum("kj,kj->k", second[rows], foot[rows])[:, None]
            cx, cy = qx[:, second_i] - qx[:, first_i], qy[:, second_i] - qy[:, first_i]
            length = np.hypot(cx, cy)
            radius = np.hypot(qx, qy)
            with np.errstate(divide="ignore", invalid="ignore"):
                wx = np.concatenate([cy / length, -qx / radius], axis=1)  # (K, C): chord normals, toward the trace
                wy = np.concatenate([-cx / length, -qy / radius], axis=1)
            products = wx[:, :, None] * qx[:, None, :] + wy[:, :, None] * qy[:, None, :]  # (K, C, H): w . q
            m = len(first_i)
            # each chord's other normal: max of -w . q = -(min of w . q)
            candidates = np.concatenate([products.max(axis=2), -products[:, :m].min(axis=2)], axis=1)
            # a degenerate candidate (coincident points, a vertex on the trace) is no direction: skip it
            candidates = np.where(np.isfinite(candidates), candidates, np.inf)
            out[rows] = candidates.min(axis=1)
        return out

    def depth(self, x: FloatArray) -> float:
        """Depth (mm) of one axis ``x = (x0, y0, a, b)``: negative when the data do not surround it."""
        from scipy.spatial import ConvexHull, QhullError

        axis = directions(np.asarray(x[None, 2:4], dtype=float))
        first, second = plane_basis(axis)
        rel = self.points - np.array([x[0], x[1], 0.0])
        planar = np.column_stack([rel @ first[0], rel @ second[0]])
        try:
            hull = ConvexHull(planar)
        except (QhullError, ValueError):
            return -np.inf
        # equations: n . p + offset <= 0 inside; the trace is the origin
        return float(-hull.equations[:, 2].max())

    def surrounded(self, x: FloatArray) -> NDArray[np.bool_]:
        """Whether the data surround each axis ``x`` (M, 4) (depth > 0; the ring polygon decides most)."""
        _, lower = self.cell_depth(x, np.zeros_like(x))
        sure = lower > 0
        return np.array([bool(sure[i]) or self.depth(row) > 0 for i, row in enumerate(x)], dtype=bool)


#: stop reason of a MIC search whose best axes run onto the edge of the surrounded axes
EDGE_REASON = "the best axes ran onto the edge of the axes the points surround"
_EDGE_RUN = 4  # generations in a row of improving incumbents ever closer to that edge
_EDGE_SHRINK = 0.75  # ... each at most this fraction of the previous one's depth
_EDGE_DEPTH = 1e-2  # ... the last within this fraction of its radius


class EdgeWatch:
    """Whether the MIC incumbents run onto the edge of the surrounded axes.

    There the supremum of the inscribed radius is approached on the edge (an axis on the
    boundary of the points' projection: no empty cylinder is surrounded), where the bounds,
    blind to the surround constraint, are only first-order in the cell size: the proof
    cannot close, so the search stops (a heuristic stop: the bound so far stays proven).
    """

    def __init__(self) -> None:
        self.history: list[tuple[float, float]] = []

    def runs_onto_edge(self, surround: Surround, value: float, x: FloatArray) -> bool:
        """Record the incumbent (objective ``value``, axis ``x``) of a generation; True when the run is on."""
        if not np.isfinite(value):
            return False
        depth = surround.depth(x)
        self.history.append((value, depth))
        recent = self.history[-(_EDGE_RUN + 1):]
        if len(recent) <= _EDGE_RUN:
            return False
        steps = itertools.pairwise(recent)
        closing = all(new[0] < old[0] and 0.0 < new[1] <= _EDGE_SHRINK * old[1] for old, new in steps)
        return closing and depth <= _EDGE_DEPTH * abs(value)
