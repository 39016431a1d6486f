"""Make the bundled GD&T example: a constructed block with three datum faces and holes, in a known pose.

The nominal part (DRF A|B|C): datum A is the face z = 0 (material above), B the face x = 0, C the face
y = 0.  Each datum face is built with a known contact set, so its tangent minimax plane is exactly
the nominal face: A has three points at z = 0 surrounding the projection of one point at z = ``DATUM_FORM_MM``
(the rest strictly between), B two points at x = 0 on either side of one at x = ``DATUM_FORM_MM`` in
the projection along z, C its lowest point at y = 0.  The holes are exact cylinders (points on the
surface, end rings at both heights) whose axis is offset and tilted by known amounts; the top face is
an exact plane tilted by a known slope.  Every point is then moved by the rigid motion
``measured = R @ nominal + t``.  Exact answers (DRF coordinates) follow from the construction:

- position of a hole RFS: ``2 max |(offset + h * tilt)|`` over the end heights ``h``;
- at MMC its bonus ``diameter - (nominal + lower deviation)``;
- parallelism of the top face to A: ``slope * extent``; perpendicularity of a hole to A (dia):
  ``depth * |tilt|``;
- a hole's x coordinate in A|B|C (its least-squares axis at z = 0): nominal + offset; the distance of
  two holes' axes at z = 0 and the angle between a hole's axis and the top face's normal likewise.

Run ``python make_gdt_example.py --overwrite`` to regenerate the plan and points next to this script;
the result depends only on ``SEED``.  :func:`make_part` is also what the tests and the benchmark use.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SEED = 20261206
DATUM_FORM_MM = 0.004
BLOCK_MM = (120.0, 90.0, 30.0)
#: points per feature of the shipped example
EXAMPLE_POINTS = 150


@dataclass
class Hole:
    """A hole's construction: nominal centre (x, y), diameter, actual offset, tilt (dx/dz, dy/dz), size."""

    name: str
    centre: tuple[float, float]
    diameter: float
    offset: tuple[float, float]
    tilt: tuple[float, float]
    actual_diameter: float
    size_tolerance: tuple[float, float] = (0.0, 0.1)
    depth: tuple[float, float] = (2.0, 28.0)

    def axis(self) -> np.ndarray:
        u = np.array([self.tilt[0], self.tilt[1], 1.0])
        return u / np.linalg.norm(u)

    def end_deviations(self) -> np.ndarray:
        """Deviations (2, 2) of the axis end points across z, DRF coordinates, mm."""
        u = self.axis()
        base = np.array([self.offset[0], self.offset[1], 0.0])
        # the end rings are at axial heights h along u from the axis point at z = 0
        return np.array([(base + h * u)[:2] for h in self.heights()])

    def heights(self) -> tuple[float, float]:
        u = self.axis()
        return self.depth[0] / u[2], self.depth[1] / u[2]

    def position_rfs(self) -> float:
        return 2.0 * float(np.linalg.norm(self.end_deviations(), axis=1).max())

    def perpendicularity(self) -> float:
        d = self.end_deviations()
        return float(np.linalg.norm(d[1] - d[0]))


@dataclass
class Part:
    """Nominal-frame points per feature, the pose and the holes."""

    points: dict[str, np.ndarray] = field(default_factory=dict)
    holes: list[Hole] = field(default_factory=list)
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    top_slope: float = 0.0
    top_extent: float = 0.0

    def measured(self, name: str) -> np.ndarray:
        return self.points[name] @ self.rotation.T + self.translation


def _rotation(rotvec: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(rotvec))
    if angle == 0:
        return np.eye(3)
    k = rotvec / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def datum_face(rng: np.random.Generator, n: int, size: tuple[float, float]) -> np.ndarray:
    """(n, 3) points of a face in local (u, v, w) with w the height above the datum plane (w >= 0).

    Contacts: indices 0, 1, 2 at w = 0 (a wide triangle), index 3 at w = DATUM_FORM_MM above a point
    inside it; the others strictly between (0.2 to 0.8 of the form).
    """
    a, b = size
    uv = rng.uniform(0.05, 0.95, (n, 2)) * [a, b]
    uv[:4] = [[0.1 * a, 0.1 * b], [0.9 * a, 0.15 * b], [0.45 * a, 0.9 * b], [0.5 * a, 0.4 * b]]
    w = rng.uniform(0.2, 0.8, n) * DATUM_FORM_MM
    w[:3] = 0.0
    w[3] = DATUM_FORM_MM
    return np.c_[uv, w]


def strip_face(rng: np.random.Generator, n: int, size: tuple[float, float]) -> np.ndarray:
    """A secondary face in local (u = along the face, z, w = height): in the projection along z the
    contacts are indices 0 and 1 at w = 0 (u far apart) and 2 at w = DATUM_FORM_MM between them."""
    a, b = size
    uz = rng.uniform(0.05, 0.95, (n, 2)) * [a, b]
    uz[:3] = [[0.1 * a, 0.5 * b], [0.9 * a, 0.3 * b], [0.5 * a, 0.6 * b]]
    w = rng.uniform(0.2, 0.8, n) * DATUM_FORM_MM
    w[:2] = 0.0
    w[2] = DATUM_FORM_MM
    return np.c_[uz, w]


def hole_points(rng: np.random.Generator, hole: Hole, n: int) -> np.ndarray:
    """Points exactly on the hole's actual cylinder, with full rings at both end heights."""
    u = hole.axis()
    e1 = np.cross(u, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    h0, h1 = hole.heights()
    ring = max(8, n // 10)
    heights = np.r_[np.full(ring, h0), np.full(ring, h1), rng.uniform(h0, h1, n - 2 * ring)]
    angles = np.r_[np.linspace(0, 2 * np.pi, ring, endpoint=False)] if ring else np.zeros(0)
    angles = np.r_[angles, angles + 0.1, rng.uniform(0, 2 * np.pi, n - 2 * ring)]
    r = hole.actual_diameter / 2.0
    base = np.array([hole.centre[0] + hole.offset[0], hole.centre[1] + hole.offset[1], 0.0])
    return base + np.outer(heights, u) + r * (np.outer(np.cos(angles), e1) + np.outer(np.sin(angles), e2))


def make_part(seed: int = SEED, *, n_points: int = 400, n_holes: int = 3, n_faces: int = 0,
              pose_deg: float = 2.0, pose_mm: float = 2.0) -> Part:
    """A constructed part (see the module docstring).

    The first hole conforms at RFS, the second needs its MMC bonus, the third fails; further holes
    (``n_holes > 3``) get random small offsets.  ``n_faces`` extra exact planar faces ``F1..`` at the top,
    parallel to A within a known slope.
    """
    rng = np.random.default_rng(seed)
    lx, ly, lz = BLOCK_MM
    part = Part()
    a = datum_face(rng, n_points, (lx, ly))
    part.points["A"] = a  # (x, y, z) = (u, v, w)
    b = strip_face(rng, n_points, (ly, lz))
    part.points["B"] = np.c_[b[:, 2], b[:, 0], b[:, 1]]  # x = w, y = u, z
    c = rng.uniform(0.05, 0.95, (n_points, 2)) * [lx, lz]
    cw = rng.uniform(0.2, 0.8, n_points) * DATUM_FORM_MM
    cw[0] = 0.0
    part.points["C"] = np.c_[c[:, 0], cw, c[:, 1]]
    # top face: z = lz + slope * (x - x0), exact plane
    part.top_slope = 2e-4
    top = rng.uniform(0.05, 0.95, (n_points, 2)) * [lx, ly]
    top[:2, 0] = [0.05 * lx, 0.95 * lx]
    part.top_extent = 0.9 * lx
    part.points["TOP"] = np.c_[top, lz + part.top_slope * (top[:, 0] - 0.5 * lx)]
    for k in range(n_faces):
        f = rng.uniform(0.05, 0.95, (n_points, 2)) * [lx, ly]
        f[:2, 0] = [0.05 * lx, 0.95 * lx]
        part.points[f"F{k + 1}"] = np.c_[f, lz + (k + 1) * 1e-5 * (f[:, 0] - 0.5 * lx)]
    specs = [((30.0, 25.0), (0.02, -0.015), (4e-4, 0.0), 10.03),
             ((90.0, 25.0), (0.05, 0.04), (0.0, 5e-4), 10.08),
             ((60.0, 65.0), (0.09, 0.0), (0.0, 0.0), 10.01)]
    for k in range(n_holes):
        if k < len(specs):
            centre, offset, tilt, dia = specs[k]
        else:
            centre = (float(rng.uniform(15, lx - 15)), float(rng.uniform(15, ly - 15)))
            offset = tuple(rng.uniform(-0.02, 0.02, 2))
            tilt = tuple(rng.uniform(-3e-4, 3e-4, 2))
            dia = float(rng.uniform(10.01, 10.09))
        hole = Hole(f"H{k + 1}", centre, 10.0, offset, tilt, dia)  # type: ignore[arg-type]
        part.holes.append(hole)
        part.points[hole.name] = hole_points(rng, hole, n_points)
    part.rotation = _rotation(np.radians(rng.uniform(-pose_deg, pose_deg, 3)))
    part.translation = rng.uniform(-pose_mm, pose_mm, 3)
    return part


def plan_text(part: Part, *, modifier: str = "MMC") -> str:
    """The TOML plan of ``part`` (points files ``NAME.csv`` beside it)."""
    lz = BLOCK_MM[2]
    out = ['units = "mm"', 'standard = "ISO"', "", "[part]", 'frame = "A|B|C"', ""]
    for name, normal in (("A", "[0, 0, -1]"), ("B", "[-1, 0, 0]"), ("C", "[0, -1, 0]")):
        out += [f"[features.{name}]", 'element = "plane"', f'points = "{name}.csv"', f"normal = {normal}", ""]
    out += ["[features.TOP]", 'element = "plane"', 'points = "TOP.csv"', "normal = [0, 0, 1]",
            f"point = [0, 0, {lz:g}]", ""]
    for hole in part.holes:
        out += [f"[features.{hole.name}]", 'element = "cylinder"', f'points = "{hole.name}.csv"',
                'side = "internal"', f"point = [{hole.centre[0]:g}, {hole.centre[1]:g}, 0]", "axis = [0, 0, 1]",
                f"diameter = {hole.diameter:g}", f"size_tolerance = [{hole.size_tolerance[0]:g}, "
                f"{hole.size_tolerance[1]:g}]", ""]
    out += ["[datums]", 'A = "A"', 'B = "B"', 'C = "C"', ""]
    chars = [("flatness A", "A", "flatness 0.01"),
             ("parallelism TOP", "TOP", "parallelism 0.05 | A"),
             ("perpendicularity H1", "H1", "⊥ ⌀0.02 | A")]
    for hole in part.holes:
        chars.append((f"position {hole.name}", hole.name, f"position dia 0.1 {modifier} | A | B | C"))
    for name, feature, frame in chars:
        out += ["[[characteristics]]", f'name = "{name}"', f'feature = "{feature}"', f'frame = "{frame}"', ""]
    if len(part.holes) >= 2:
        h1, h2 = part.holes[0], part.holes[1]
        distance = float(np.hypot(h2.centre[0] - h1.centre[0], h2.centre[1] - h1.centre[1]))
        out += ["[[characteristics]]", 'name = "x H1"', 'type = "coordinate"', 'feature = "H1"', 'axis = "x"',
                f"nominal = {h1.centre[0]:g}", "limits = [-0.05, 0.05]", "",
                "[[characteristics]]", 'name = "H1 to H2"', 'type = "distance"', 'features = ["H1", "H2"]',
                f"nominal = {distance:g}", "limits = [-0.1, 0.1]", "",
                "[[characteristics]]", 'name = "H1 to TOP"', 'type = "angle"', 'features = ["H1", "TOP"]',
                "nominal_deg = 0", "limits_deg = [0, 0.05]", ""]
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out-dir", type=Path, default=Path(__file__).resolve().parent)
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args()
    part = make_part(n_points=EXAMPLE_POINTS)
    files = {f"{name}.csv": part.measured(name) for name in part.points}
    targets = [args.out_dir / name for name in [*files, "plan.toml"]]
    if not args.overwrite and any(t.exists() for t in targets):
        raise SystemExit("files exist; pass --overwrite")
    args.out_dir.mkdir(parents=True, exist_ok=True)
    for name, pts in files.items():
        np.savetxt(args.out_dir / name, pts, fmt="%.9f", delimiter=",")
    (args.out_dir / "plan.toml").write_text(plan_text(part), encoding="utf-8")


if __name__ == "__main__":
    main()
