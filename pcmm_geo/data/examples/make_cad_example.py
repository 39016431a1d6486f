"""Make the bundled CAD-comparison example: a simulated scan of a 100 mm gauge block and its nominal mesh.

The nominal block (100 x 35 x 9 mm, centred at the origin, length along x) is probed on
its top face and its four sides (the bottom rests on the table), 0.2 mm away from the
edges, like a touch-trigger scan.  Each point gets Gaussian probing noise of 1 µm along
the face normal and is then placed in the machine frame by a known rigid pose:
``machine = R @ nominal + t`` with ``R`` a rotation by ``ROTATION_VECTOR_DEG`` (degrees,
rotation-vector form) and ``t = TRANSLATION_MM``.  Registering the scan to the nominal
mesh should therefore return ``R.T`` and ``-R.T @ t``.

Files written next to this script (or to ``--out-dir``)::

    gauge_block_scan.csv        x,y,z in mm, rounded to 1 nm
    gauge_block_nominal.stl     the nominal block (binary STL; every vertex exact in float32)
    gauge_block_scan_pose.json  the pose, noise and seed used

Run ``python make_cad_example.py --overwrite`` to regenerate them (without ``--overwrite``
nothing is written while any of the three exists); the result depends only on ``SEED``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

SEED = 20240610
BLOCK_SIZE_MM = (100.0, 35.0, 9.0)
ROTATION_VECTOR_DEG = (0.4, -0.25, 1.5)
TRANSLATION_MM = (1.2, -0.7, 0.35)
NOISE_MM = 0.001
EDGE_MARGIN_MM = 0.2
#: points per square millimetre of probed face
DENSITY_PER_MM2 = 0.5

SCAN_NAME = "gauge_block_scan.csv"
MESH_NAME = "gauge_block_nominal.stl"
POSE_NAME = "gauge_block_scan_pose.json"


def rotation_matrix(rotation_vector_rad: np.ndarray) -> np.ndarray:
    """Rotation by ``|v|`` rad about ``v`` (Rodrigues)."""
    angle = float(np.linalg.norm(rotation_vector_rad))
    if angle == 0.0:
        return np.eye(3)
    x, y, z = rotation_vector_rad / angle
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * (cross @ cross)


def pose() -> np.ndarray:
    """The scan's pose (4, 4): machine = R @ nominal + t."""
    transform = np.eye(4)
    transform[:3, :3] = rotation_matrix(np.radians(ROTATION_VECTOR_DEG))
    transform[:3, 3] = TRANSLATION_MM
    return transform


def nominal_scan(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Points on the top face and the four sides in the nominal frame, and their outward normals."""
    half = 0.5 * np.asarray(BLOCK_SIZE_MM)
    points, normals = [], []
    # (axis of the normal, sign): top +z, sides +-y, ends +-x
    for axis, sign in ((2, 1.0), (1, 1.0), (1, -1.0), (0, 1.0), (0, -1.0)):
        in_plane = [k for k in range(3) if k != axis]
        extent = 2.0 * (half[in_plane] - EDGE_MARGIN_MM)
        count = round(DENSITY_PER_MM2 * float(np.prod(extent)))
        face = np.empty((count, 3))
        face[:, in_plane] = rng.uniform(-1.0, 1.0, (count, 2)) * (half[in_plane] - EDGE_MARGIN_MM)
        face[:, axis] = sign * half[axis]
        normal = np.zeros(3)
        normal[axis] = sign
        points.append(face)
        normals.append(np.tile(normal, (count, 1)))
    return np.vstack(points), np.vstack(normals)


def make_scan(seed: int = SEED) -> np.ndarray:
    """The example scan (N, 3) in the machine frame, mm, rounded to 1 nm."""
    rng = np.random.default_rng(seed)
    points, normals = nominal_scan(rng)
    probed = points + NOISE_MM * rng.standard_normal(len(points))[:, None] * normals
    transform = pose()
    return np.round(probed @ transform[:3, :3].T + transform[:3, 3], 6)


def main(argv: list[str] | None = None) -> int:
    from pcmm_geo.errors import OutputExistsError
    from pcmm_geo.io.meshes import box_mesh, write_mesh
    from pcmm_geo.io.points import write_points

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out-dir", type=Path, default=Path(__file__).resolve().parent)
    parser.add_argument("--overwrite", action="store_true", help="replace existing files")
    args = parser.parse_args(argv)
    if not args.overwrite:  # all three or none: refuse before writing anything
        for name in (SCAN_NAME, MESH_NAME, POSE_NAME):
            if (args.out_dir / name).exists():
                raise OutputExistsError(str(args.out_dir / name))
    scan = make_scan()
    write_points(args.out_dir / SCAN_NAME, scan, overwrite=args.overwrite)
    write_mesh(args.out_dir / MESH_NAME, box_mesh(*BLOCK_SIZE_MM), overwrite=args.overwrite)
    description = {
        "block_size_mm": list(BLOCK_SIZE_MM),
        "pose": "machine = R @ nominal + t",
        "rotation_vector_deg": list(ROTATION_VECTOR_DEG),
        "translation_mm": list(TRANSLATION_MM),
        "transform": pose().tolist(),
        "noise_mm": NOISE_MM,
        "edge_margin_mm": EDGE_MARGIN_MM,
        "point_count": len(scan),
        "seed": SEED,
    }
    pose_file = args.out_dir / POSE_NAME
    with open(pose_file, "w" if args.overwrite else "x", encoding="utf-8") as handle:
        json.dump(description, handle, indent=2)
        handle.write("\n")
    print(f"wrote {len(scan)} points to {args.out_dir / SCAN_NAME}, {MESH_NAME} and {POSE_NAME}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
