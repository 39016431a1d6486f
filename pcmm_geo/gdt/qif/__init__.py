"""The second opinion on a QIF results file's characteristics, recomputed from its feature actuals.

:mod:`~pcmm_geo.gdt.qif.frames` builds datum reference frames from the datum features' actuals,
:mod:`~pcmm_geo.gdt.qif.measures` and :mod:`~pcmm_geo.gdt.qif.orientation` recompute the values,
:mod:`~pcmm_geo.gdt.qif.characteristics` compares them with what the file reports
(:func:`~pcmm_geo.gdt.qif.characteristics.verify_characteristics`).
"""
