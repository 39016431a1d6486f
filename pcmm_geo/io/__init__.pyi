"""Type stub of :mod:`pcmm_geo.io`: lazy public names, real types (pcmm_geo._lazy)."""

from .labelled import LabelledPoints as LabelledPoints
from .labelled import read_labelled_points as read_labelled_points
from .lazy import read_points_lazy as read_points_lazy
from .meshes import box_mesh as box_mesh
from .meshes import cylinder_mesh as cylinder_mesh
from .meshes import nominal_mesh as nominal_mesh
from .meshes import read_mesh as read_mesh
from .meshes import sphere_mesh as sphere_mesh
from .meshes import write_mesh as write_mesh
from .nist import NistPair as NistPair
from .nist import iter_nist_pairs as iter_nist_pairs
from .nist import read_nist_pair as read_nist_pair
from .points import read_points as read_points
from .points import write_points as write_points
