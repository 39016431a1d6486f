"""Exact, global minimax solvers on convex hulls and Voronoi diagrams (scipy.spatial / Qhull).

- :mod:`.slab`: narrowest strip (2-D line zone, rotating calipers) and slab (plane zone, the
  nearest facet of the hull's difference body);
- :mod:`.annulus`: minimum-zone circle / sphere and smallest enclosing ball, exact on a subset
  grown by the violating points;
- :mod:`.empty`: largest empty circle / sphere centred in the convex hull (maximum inscribed);
- :mod:`.polish`: Newton's method on the KKT system of the exact optimum's contacts.

Each returns an :class:`~pcmm_geo.fit.zone._exact._optimum.ExactOptimum` with the proven bound.
"""
