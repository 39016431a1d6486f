"""Global minimax fits of axial elements: branch and bound over axis cells.

* :mod:`~pcmm_geo.fit.zone.axial.region` -- the axis region (:class:`AxisRegion`) and the
  search budget (:class:`SearchBudget`);
* :mod:`~pcmm_geo.fit.zone.axial.bounds` -- rigorous bounds of the point distances over a cell of axes;
* :mod:`~pcmm_geo.fit.zone.axial.search` -- the branch and bound;
* :mod:`~pcmm_geo.fit.zone.axial.polish` -- local solves of the incumbent inside the region;
* :mod:`~pcmm_geo.fit.zone.axial.surround` -- the domain of the maximum inscribed cylinder;
* :mod:`~pcmm_geo.fit.zone.axial.solve` -- set-up for cylinders and 3-D lines.
"""

from pcmm_geo.fit.zone.axial.region import AxisRegion, SearchBudget

__all__ = ["AxisRegion", "SearchBudget"]
