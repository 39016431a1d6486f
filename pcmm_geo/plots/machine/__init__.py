"""Figures of the machine itself: the tetrahedron calibration (thesis fig 7.2), the numerical
calibration, poses and trilateration (``machine_state``), a processed measurement log and the
reading-to-tip sensitivity map.

The public names are offered by :mod:`pcmm_geo.plots` (``plot_calibration``, ``plot_pose``, ...),
loaded on first use.  May import what :mod:`pcmm_geo.plots` may (fit, machine, acquisition,
artefacts and below) and ``pcmm_geo.plots._figure``; matplotlib only inside the functions.
"""
