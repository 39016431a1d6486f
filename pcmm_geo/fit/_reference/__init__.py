"""Private parts of the reference-data generator :mod:`pcmm_geo.fit.reference`.

What lives here: the reference data set and per-element generators (``elements``) and
reading/writing of reference data sets (``io``).  Users import them from
:mod:`pcmm_geo.fit.reference`, which re-exports what is public.

May import: :mod:`pcmm_geo.errors`, numpy, :mod:`pcmm_geo.fit._kernels` and each other; never
:mod:`pcmm_geo.fit.reference` (which imports them) or anything above :mod:`pcmm_geo.fit`.
"""
