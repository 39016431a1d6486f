"""Verify a fitting software with ISO 10360-6 (user guide, example 1).

Two steps: (1) make reference data sets with known least-squares solutions and check
pcmm_geo's own fits against them; (2) compare another software's answers (a results file)
with reference parameters, with the maximum permissible errors (MPE) of the test.
"""

from importlib.resources import files

from pcmm_geo.artefacts.iso10360_6 import HarnessMpe, cases_from_reference_data, compare_results, fit_with_pcmm_geo
from pcmm_geo.artefacts.iso10360_6_io import load_reference_cases, read_element_parameters
from pcmm_geo.fit.reference import make_reference_data

# 1. Null-space reference data: points whose Gaussian fit is known exactly (seeded).
datasets = [make_reference_data(element, form=0.002, rng=seed)
            for seed, element in enumerate(["plane", "sphere", "cylinder", "cone", "circle3d", "torus"])]
cases = cases_from_reference_data(datasets, prefix="ref")
own = compare_results(cases, fit_with_pcmm_geo(cases), HarnessMpe())  # MPE 1e-9 mm / 1e-9 rad
print(f"pcmm_geo on {len(cases)} reference sets: {'PASS' if own.passed else 'FAIL'}")
for kind in ("position", "orientation", "size"):
    print(f"  largest {kind} deviation below 1e-9: {own.max_deviation(kind) < 1e-9}")

# 2. Another software's results against reference parameters (bundled example files).
examples = files("pcmm_geo") / "data" / "examples"
reference = load_reference_cases(examples / "iso10360_6_reference.csv")
results = read_element_parameters(examples / "iso10360_6_results.json")
report = compare_results(reference, results, HarnessMpe(position=1e-6, orientation=1e-6, size=1e-6, angle=1e-6))
print(f"tested software: {'PASS' if report.passed else 'FAIL'}, {report.n_failed} of {len(report.cases)} cases fail")
for case in report.cases:
    verdict = "pass" if case.passed else "FAIL"
    print(f"  {case.name:<11} {case.element:<9} size deviation {case.size * 1e3:8.4f} um  {verdict}")
