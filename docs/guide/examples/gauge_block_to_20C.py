"""Evaluate a gauge block and correct its length to 20 °C (user guide, example 3).

The points of each face come from one labelled point file (``label,x,y,z``).  The ISO 3650
central length is measured at the workpiece temperature, then corrected to the reference
temperature of 20 °C (ISO 1) with a GUM uncertainty budget.
"""

from importlib.resources import files

from pcmm_geo.artefacts.gauge_block import measure_gauge_block, read_gauge_block_csv
from pcmm_geo.thermal.correction import correct_length

points = read_gauge_block_csv(files("pcmm_geo") / "data" / "examples" / "gauge_block.csv")
block = measure_gauge_block(points)
print(f"faces: {dict(block.n_points)}")
print(f"central length at 21.5 °C: {block.central_length:.6f} mm")
print(f"variation in length: {block.variation_in_length * 1e3:.2f} µm")

# Steel block at 21.5 °C (u = 0.05 K), alpha = 11.5e-6 /K (u = 1e-6 /K); machine scale compensated.
corrected = correct_length(
    block.central_length, 21.5, 11.5e-6,
    u_measured_length=0.5e-3, u_temperature_workpiece=0.05, u_alpha_workpiece=1e-6,
)
print(f"length at 20 °C: {corrected.value:.6f} mm (correction {corrected.correction * 1e3:.3f} µm)")
print(f"expanded uncertainty U (k = 2): {corrected.expanded_uncertainty() * 1e3:.2f} µm")
for entry in corrected.budget:
    print(f"  {entry.quantity:<22} {entry.contribution * 1e3:7.3f} µm")
