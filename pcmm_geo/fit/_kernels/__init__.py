"""Private numerical kernels of :mod:`pcmm_geo.fit` (not public API; import the element modules).

What lives here: input validation, the result base class and tolerances (``_core``); the
least-squares kernels shared by several elements -- principal frames and covariance of lines
and planes (``_linear``), circles and spheres (``_round``), cylinders and cones (``_axial``,
``_axial_lm``), the normal-equation path for tall problems (``_tall``) and the torus start
search (``_torus_search``).  One implementation of each geometric kernel: the public element
modules (``fit.line``, ``fit.plane``, ...) and the minimum-zone solvers of :mod:`pcmm_geo.fit.zone`
both build on these.

May import: :mod:`pcmm_geo.errors`, numpy, scipy and each other.  Never the public element
modules, :mod:`pcmm_geo.fit.zone` or anything above :mod:`pcmm_geo.fit`.
"""
