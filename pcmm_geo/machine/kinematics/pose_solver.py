"""The rigid-body model's arrays and closure geometry, for the analyses built on it (log processing).

The batched Gauss-Newton closure solver lives in the private
:mod:`pcmm_geo.machine.kinematics._pose_solver`; what other packages use of it is public here:

=================================  ===============================================================
name                               what it is
=================================  ===============================================================
:class:`Geometry`                  the machine geometry as stacked arrays (arm order a, b, c)
:func:`joints_in_tetrahedron`      joint centres ``q_i + s_i w_i`` in the tetrahedron frame
                                   (thesis ch. 5), ``(K, 3, 3)``
:func:`pivots_in_machine`          pivot centres ``c_i + e_i H_i v_i`` in the machine frame,
                                   ``(K, 3, 3)``
:func:`kabsch`                     the proper rigid transform ``target ~ R source + t`` of batches
:func:`skew`                       cross-product matrices ``[v]_x``
=================================  ===============================================================

Examples
--------
>>> import numpy as np
>>> skew(np.array([0.0, 0.0, 1.0])) @ np.array([1.0, 0.0, 0.0])
array([0., 1., 0.])
"""

from __future__ import annotations

from pcmm_geo.machine.kinematics._pose_solver import Geometry, joints_in_tetrahedron, kabsch, pivots_in_machine, skew

__all__ = ["Geometry", "joints_in_tetrahedron", "kabsch", "pivots_in_machine", "skew"]
