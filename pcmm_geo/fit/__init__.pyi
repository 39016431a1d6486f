"""Type stub of :mod:`pcmm_geo.fit`: lazy public names, real types (pcmm_geo._lazy)."""

from . import reference as reference
from ._kernels._core import TOL as TOL
from ._kernels._core import FitResult as FitResult
from ._kernels._core import Tolerances as Tolerances
from ._kernels._core import as_points as as_points
from ._kernels._core import rotation_to_z as rotation_to_z
from .batch import BatchFit as BatchFit
from .batch import CircleBatchFit as CircleBatchFit
from .batch import LineBatchFit as LineBatchFit
from .batch import PlaneBatchFit as PlaneBatchFit
from .batch import SphereBatchFit as SphereBatchFit
from .batch import fit_circles as fit_circles
from .batch import fit_lines as fit_lines
from .batch import fit_planes as fit_planes
from .batch import fit_spheres as fit_spheres
from .circle import CircleFit as CircleFit
from .circle import fit_circle as fit_circle
from .cone import ConeFit as ConeFit
from .cone import fit_cone as fit_cone
from .cylinder import CylinderFit as CylinderFit
from .cylinder import fit_cylinder as fit_cylinder
from .line import LineFit as LineFit
from .line import fit_line as fit_line
from .plane import PlaneFit as PlaneFit
from .plane import fit_plane as fit_plane
from .probe import ProbeCompensation as ProbeCompensation
from .probe import compensate_points as compensate_points
from .probe import compensate_probe as compensate_probe
from .probe import material_side_from_nominal as material_side_from_nominal
from .probe import material_side_from_normals as material_side_from_normals
from .skew import LinePair as LinePair
from .skew import LinesNearestPoint as LinesNearestPoint
from .skew import angle_between as angle_between
from .skew import closest_points as closest_points
from .skew import mean_pairwise_midpoint as mean_pairwise_midpoint
from .skew import nearest_point_to_lines as nearest_point_to_lines
from .skew import pairwise_closest_points as pairwise_closest_points
from .sphere import SphereFit as SphereFit
from .sphere import fit_sphere as fit_sphere
from .torus import TorusFit as TorusFit
from .torus import fit_torus as fit_torus
from .zone.axial.region import AxisRegion as AxisRegion
from .zone.axial.region import SearchBudget as SearchBudget

ELEMENTS: tuple[str, ...]
