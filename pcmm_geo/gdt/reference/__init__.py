"""Datum features and datum reference frames (ISO 5459-1/-2; ASME Y14.5-2018, Y14.5.1-2019).

:mod:`~pcmm_geo.gdt.reference.datums` associates a datum feature (with its certificate),
:mod:`~pcmm_geo.gdt.reference.drf` builds a datum reference frame from up to three of them,
:mod:`~pcmm_geo.gdt.reference.frame` holds the frame itself and the degrees of freedom it leaves
free. The public names are re-exported by :mod:`pcmm_geo.gdt`.
"""
