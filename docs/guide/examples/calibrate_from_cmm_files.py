"""Calibrate the micro-CMM's tetrahedron from external-CMM files (user guide, example 2).

Inputs are the two files a calibration session produces: the external CMM's probings of the
three joint spheres and the probe tip at each slider position, and the laser readings at
those positions.  The bundled files are rebuilt from the thesis' appendices C and D.
"""

import tempfile
from importlib.resources import files
from pathlib import Path

from pcmm_geo.machine.calibration import calibrate_tetrahedron, load_calibration, save_calibration
from pcmm_geo.machine.calibration.probings import read_lasers, read_probings

data = files("pcmm_geo") / "data" / "appendix_cd"
probings = read_probings(data / "cmm_export.csv")  # element export: x,y,z,d,r per sphere
lasers = read_lasers(data / "lasers.csv")  # position,laser_a,laser_b,laser_c (mm)
cal = calibrate_tetrahedron(probings, lasers)

print("arm  d / mm    pair  beta / deg  b / mm")
for arm, pair in zip("abc", ("ab", "bc", "ca"), strict=True):
    print(f"{arm}    {cal.dead_distance[arm]:8.3f}  {pair}    {cal.beta_deg[pair]:8.3f}  {cal.b_in[pair]:8.3f}")
print(f"beta_ab = {cal.beta['ab']:.6f} rad (the API is in radians; beta_deg is for people)")
print("skew distances / mm:", {pair: round(value, 3) for pair, value in cal.skew_distances.items()})

# A versioned calibration file: never overwritten unless asked; reading it recomputes and checks.
path = save_calibration(cal, Path(tempfile.mkdtemp()) / "tetrahedron.json")
again = load_calibration(path)
print("file read back, same dead distances:", again.dead_distance == cal.dead_distance)
