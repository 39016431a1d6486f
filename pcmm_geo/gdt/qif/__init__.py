"""The second opinion on a QIF results file's characteristics, recomputed from its feature actuals.

:mod:`~pcmm_geo.gdt.qif.frames` builds datum reference frames from the datum features' actuals,
:mod:`~pcmm_geo.gdt.qif.measures` and :mod:`~pcmm_geo.gdt.qif.orientation` recompute the values,
:mod:`~pcmm_geo.gdt.qif.characteristics` compares them with what the file reports
(:func:`~pcmm_geo.gdt.qif.characteristics.verify_characteristics`).  The other way,
:mod:`~pcmm_geo.gdt.qif.results` writes an inspection plan's results as a QIF 3.0 results file
(:func:`~pcmm_geo.gdt.qif.results.inspection_to_qif`).
"""
