"""Reports list every result their standard asks for (ISO 10360-2 clause 7, ISO/IEC 17025 7.8).

Each value is recomputed here from the input file (E0 = measured − calibrated, R0 = range of
the repetitions, the sphere residuals from the reported centre and diameter, the ISO 3650
limits from the standard's table, the thermal correction in closed form) and looked up in the
rendered report, parsed back from its HTML or Markdown; a report with one row removed is caught.
"""

from __future__ import annotations

import csv
import json
import math
from html.parser import HTMLParser
from pathlib import Path

import pytest
from pcmm_runner import run_pcmm

import pcmm_geo

EXAMPLES = Path(pcmm_geo.__file__).parent / "data" / "examples"
LENGTHS = EXAMPLES / "iso10360_2_lengths.csv"
SPHERE = EXAMPLES / "iso10360_5_sphere.csv"
GAUGE = EXAMPLES / "gauge_block.csv"
WHO = ("--laboratory", "Dimensional Metrology Laboratory")


class _Tables(HTMLParser):
    """``{h2 title: rows of cell texts}`` of an HTML report."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: dict[str, list[list[str]]] = {}
        self.title = ""
        self.in_title = False
        self.cell: list[str] | None = None
        self.row: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "h2":
            self.in_title, self.title = True, ""
        elif tag in ("td", "th"):
            self.cell = []
        elif tag == "tr":
            self.row = []

    def handle_endtag(self, tag: str) -> None:
        if tag == "h2":
            self.in_title = False
            self.tables.setdefault(self.title, [])
        elif tag in ("td", "th") and self.cell is not None:
            self.row.append("".join(self.cell).strip())
            self.cell = None
        elif tag == "tr":
            self.tables.setdefault(self.title, []).append(self.row)

    def handle_data(self, data: str) -> None:
        if self.in_title:
            self.title += data
        elif self.cell is not None:
            self.cell.append(data)


def html_tables(path: Path) -> dict[str, list[list[str]]]:
    parser = _Tables()
    parser.feed(path.read_text(encoding="utf-8"))
    return parser.tables


def markdown_tables(path: Path) -> dict[str, list[list[str]]]:
    tables: dict[str, list[list[str]]] = {}
    title = ""
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            title = line[3:].replace("\\", "")
            tables[title] = []
        elif line.startswith("| ") and not set(line) <= set("|-: "):
            tables[title].append([c.strip().replace("\\", "") for c in line.strip().strip("|").split(" | ")])
    return tables


def expected_length_test(u_um: float, a_um: float, k: float) -> tuple[dict, dict]:
    """E0, MPE (µm) and ISO 14253-1 verdict per (length, position, repetition); R0 (µm) per (length, position)."""
    e0, groups = {}, {}
    with LENGTHS.open(encoding="utf-8") as handle:
        for row in csv.DictReader(line for line in handle if not line.startswith("#")):
            calibrated, measured = float(row["calibrated_length"]), float(row["measured_length"])
            error = 1000 * (measured - calibrated)
            mpe = a_um + calibrated / k
            verdict = "PASS" if abs(error) + u_um <= mpe else ("FAIL" if abs(error) - u_um > mpe else "NOT PROVEN")
            e0[(row["length_id"], row["position"], int(row["repetition"]))] = (error, mpe, verdict)
            groups.setdefault((row["length_id"], row["position"]), []).append(1000 * measured)
    return e0, {key: max(values) - min(values) for key, values in groups.items()}


def missing_values(rows: list[list[str]], expected: dict, r0: bool = False) -> list[str]:
    """What the report's rows lack of ``expected`` (each value to its 3 printed decimals, 1e-6 µm margin)."""
    found = {}
    for row in rows[1:]:  # without the header
        key = (row[0], row[1]) if r0 else (row[0], row[1], int(row[2]))
        found[key] = row
    problems = []
    for key, value in expected.items():
        row = found.get(key)
        if row is None:
            problems.append(f"{key}: no row")
        elif r0 and abs(float(row[3]) - value) > 0.0005 + 1e-6:
            problems.append(f"{key}: R0 {row[3]} != {value:.4f}")
        elif not r0 and (abs(float(row[4]) - value[0]) > 0.0005 + 1e-6 or abs(float(row[5]) - value[1]) > 0.0005
                         + 1e-6 or row[8] != value[2]):
            problems.append(f"{key}: {row[4:]} != {value}")
    return problems + ([f"{len(found)} rows for {len(expected)} values"] if len(found) != len(expected) else [])


@pytest.mark.parametrize(("a_um", "k", "u_um", "code", "verdict"), [
    (2.0, 100.0, 0.3, 0, "PASS"),  # every |E0| + U <= MPE
    (1.5, 333.0, 0.5, 1, "NOT PROVEN"),  # one value lies within U of its MPE
])
def test_iso10360_2_report_lists_every_e0_and_r0(tmp_path: Path, a_um: float, k: float, u_um: float, code: int,
                                                 verdict: str) -> None:
    e0, r0 = expected_length_test(u_um, a_um, k)
    assert len(e0) == 105 and len(r0) == 35
    assert (verdict == "NOT PROVEN") == any(v[2] == "NOT PROVEN" for v in e0.values())
    html, md = tmp_path / "r.html", tmp_path / "r.md"
    for page in (html, md):
        done = run_pcmm("iso10360-2", str(LENGTHS), "--mpe-a-um", str(a_um), "--mpe-k", str(k), "--uncertainty-um",
                        str(u_um), "--mpl-r0-um", "1.5", "--report", str(page), *WHO)
        assert done.returncode == code, done.stderr
        assert f"ISO 10360-2: {verdict}" in done.stdout and "Results: all 105" not in done.stdout  # terminal: summary
    for tables in (html_tables(html), markdown_tables(md)):
        e0_rows = tables["Results: all 105 length measurement errors E0"]
        assert e0_rows[0] == ["length", "position", "repetition", "L / mm", "E0 / µm", "MPE_E0 / µm",
                              "U / µm (k = 2)", "|E0| / MPE", "verdict"]
        assert missing_values(e0_rows, e0) == []
        assert {row[6] for row in e0_rows[1:]} == {f"{u_um:.3f}"}
        r0_rows = tables["Results: all 35 repeatability ranges R0"]
        assert missing_values(r0_rows, r0, r0=True) == []
        assert {row[4] for row in r0_rows[1:]} == {"1.500"} and {row[5] for row in r0_rows[1:]} == {"PASS"}
    # the check catches a report that leaves out one value, or prints another verdict
    rows = html_tables(html)["Results: all 105 length measurement errors E0"]
    assert missing_values(rows[:40] + rows[41:], e0) != []
    tampered = [row[:8] + (["FAIL"] if i == 7 else row[8:]) for i, row in enumerate(rows)]
    assert missing_values(tampered, e0) != []


def test_iso10360_5_report_lists_both_values_and_every_residual(tmp_path: Path) -> None:
    page = tmp_path / "p5.html"
    done = run_pcmm("iso10360-5", str(SPHERE), "--mpe-form-um", "1.5", "--mpe-size-um", "1.5", "--uncertainty-um",
                    "0.2", "0.2", "--report", str(page), "--json", *WHO)
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    tables = html_tables(page)
    values = {row[0].split(" ")[0]: row[1:] for row in tables["Results: probing form error P_FTU and size error "
                                                                "P_STU"][1:]}
    assert values["P_FTU"] == [f"{data['p_ftu_um']:.3f}", "1.500", "0.200", "PASS"]
    assert values["P_STU"] == [f"{data['p_stu_um']:.3f}", "1.500", "0.200", "PASS"]
    with SPHERE.open(encoding="utf-8") as handle:
        points = [[float(v) for v in row] for row in csv.reader(line for line in handle if line[0] not in "#x")]
    radius = data["fitted_diameter_mm"] / 2
    residuals = [1000 * (math.dist(p, data["centre_mm"]) - radius) for p in points]
    rows = tables["Results: residuals of the 25 probed points from the Gaussian sphere"][1:]
    assert len(rows) == 25
    for row, residual in zip(rows, residuals, strict=True):
        assert abs(float(row[4]) - residual) <= 0.0005 + 1e-6
    assert max(residuals) - min(residuals) == pytest.approx(data["p_ftu_um"], abs=1e-6)


def test_gauge_block_report_is_a_calibration_certificate(tmp_path: Path) -> None:
    page = tmp_path / "gb.html"
    done = run_pcmm("gauge-block", str(GAUGE), "--nominal-mm", "100", "--grade", "2", "--uncertainty-um", "0.1",
                    "--block-temperature-c", "20.4", "--u-block-temperature-k", "0.02", "--air-temperature-c", "20.1",
                    "--report", str(page), "--json", *WHO)
    data = json.loads(done.stdout)
    text = page.read_text(encoding="utf-8")
    assert "<h1>Calibration certificate: gauge block (ISO 3650)</h1>" in text
    # thermal correction in closed form: L20 = L_m / (1 + alpha (T - 20))
    measured = data["central_length_as_measured_mm"]
    assert data["central_length_mm"] == pytest.approx(measured / (1 + 11.5e-6 * 0.4), abs=1e-12)
    assert data["thermal_correction_um"] == pytest.approx(-1000 * measured * 11.5e-6 * 0.4, abs=2e-4)
    tables = html_tables(page)
    certified = {row[0]: row[1] for row in tables["Certified values"][1:]}
    deviation = 1000 * (data["central_length_mm"] - 100.0)
    assert certified["central length l_c at 20 °C"] == f"{data['central_length_mm']:.6f}"
    assert certified["deviation e = l_c − l_n"] == f"{deviation:+.3f}"
    assert certified["expanded uncertainty U of l_c and e (k = 2, ≈ 95 %)"] == "0.100"
    assert certified["limit deviation t_e, grade 2 (ISO 3650)"] == "±1.20"  # ISO 3650, 75 mm < l_n <= 100 mm
    assert certified["tolerance t_v for v, grade 2 (ISO 3650)"] == "0.35"
    assert certified["variation in length v"] == f"{1000 * data['variation_in_length_mm']:.3f}"
    # v = 1.37 µm (0.3 µm probing noise) exceeds t_v = 0.35 µm: FAIL, though e is within t_e with U
    assert abs(deviation) + 0.1 <= 1.20 and done.returncode == 1 and data["verdict"] == "FAIL"
    decision = {row[0]: row[1] for row in tables["Decision"][1:] if len(row) > 1}
    assert "exceeds t_v = 0.35 µm" in decision["conformity (ISO 14253-1)"]  # v fails, not proven: no U on v
    assert decision["conformity (ISO 14253-1)"].endswith("deviation e: PASS")
    conditions = {row[0]: row[1] for row in tables["Environmental conditions"][1:]}
    assert conditions["air temperature"] == "20.10" and conditions["gauge block temperature"].startswith("20.400")
    assert conditions["correction to 20 °C applied to every length"].startswith(f"{data['thermal_correction_um']:+.3f}")
    for heading in ("Method", "Measurement uncertainty", "Traceability"):
        assert f"<h2>{heading}</h2>" in text
    assert "not wrung" in text and "coverage probability of approximately 95 %" in text
    annex = {row[0]: row for row in tables["Supplementary information (not certified)"][1:]}
    assert annex["two-point distance of that point pair"][1] == f"{data['seed']['two_point_distance_mm']:.6f}"
    assert all(row[3] for row in annex.values())  # each with its meaning
    assert text.index("Certified values") < text.index("Technical annex") < text.index("Supplementary information")
    assert "thesis" not in text.lower() and "written to" not in text and "none entered" not in text
    assert "approved by (name, function)" in text


def test_a_report_naming_nobody_is_warned_about(tmp_path: Path) -> None:
    done = run_pcmm("gauge-block", str(GAUGE), "--report", str(tmp_path / "a.md"))
    assert done.returncode == 0
    assert done.stderr.count("\n") == 1 and "warning: the report states no laboratory" in done.stderr
    named = run_pcmm("gauge-block", str(GAUGE), "--report", str(tmp_path / "b.md"), "--customer", "Example Gauges")
    assert named.returncode == 0 and named.stderr == ""
    quiet = run_pcmm("gauge-block", str(GAUGE))  # no report, nothing to warn about
    assert quiet.stderr == ""


def test_gauge_block_grade_needs_a_nominal_within_the_table(tmp_path: Path) -> None:
    for extra, needle in ((["--grade", "K"], "--nominal-mm as well"),
                          (["--grade", "K", "--nominal-mm", "600"], "0.5 mm to 500 mm"),
                          (["--grade", "K", "--nominal-mm", "100", "--tolerance-um", "0.3"], "either"),
                          (["--block-temperature-c", "nan"], "--block-temperature-c")):
        done = run_pcmm("gauge-block", str(GAUGE), *extra)
        assert done.returncode == 2 and len(done.stderr.splitlines()) == 1 and needle in done.stderr, done.stderr


QIF_SAMPLE = Path(__file__).parents[1] / "data" / "qif" / "samples" / "QIF_PTS_SAMPLE.QIF"
CALYPSO = Path(__file__).parents[1] / "data" / "cmm" / "flange_chr.txt"


def test_qif_verify_report_shows_reported_and_refitted_values_as_an_agreement_check(tmp_path: Path) -> None:
    page = tmp_path / "v.html"
    done = run_pcmm("qif", "verify", str(QIF_SAMPLE), "--report", str(page), "--json", *WHO)
    assert done.returncode == 1, done.stderr
    features = {f["id"]: f for f in json.loads(done.stdout)["features"]}
    tables = html_tables(page)
    rows = {(int(row[0]), row[2]): row for row in tables["Reported and refitted values"][1:]}
    # the cylinder's diameter: both values as the file and the refit give them, and their difference
    cylinder = rows[(796, "diameter / mm")]
    assert cylinder[3] == f"{features[796]['reported']['diameter_mm']:.6f}"
    assert cylinder[4] == f"{features[796]['refit']['diameter_mm']:.6f}" and cylinder[7] == "yes"
    # the plane's location: three coordinates each, 1.79 µm apart (> 0.1 µm): does not agree
    plane = rows[(11, "location x, y, z / mm")]
    assert plane[3] == ", ".join(f"{v:.6f}" for v in features[11]["reported"]["location_mm"])
    assert plane[4] == ", ".join(f"{v:.6f}" for v in features[11]["refit"]["location_mm"])
    assert plane[5] == "1.791 µm" and plane[7] == "NO"
    decision = {row[0]: row[1] for row in tables["Decision"][1:] if len(row) > 1}
    assert "conformity (ISO 14253-1)" not in decision and decision["kind of decision"].startswith(
        "not a conformity decision")
    conditions = {row[0]: row[1] for row in tables["Environmental conditions"][1:]}
    assert list(conditions) == ["temperature"] and "same measured points" in conditions["temperature"]
    assert "20 °C" not in page.read_text(encoding="utf-8")


def test_qif_verify_of_a_table_without_points_says_nothing_was_verified(tmp_path: Path) -> None:
    page = tmp_path / "c.md"
    done = run_pcmm("qif", "verify", str(CALYPSO), "--units", "mm", "--report", str(page), *WHO)
    assert done.returncode == 1
    assert "Second opinion on" not in done.stdout  # no empty feature table
    assert "CALYPSO characteristics table was read" in done.stdout and "nothing was verified" in done.stdout
    text = page.read_text(encoding="utf-8")
    checked = markdown_tables(page)["What was checked"]
    assert checked == [] and "Not checked: any reported size" in text


def test_qif_show_writes_a_report_and_verify_draws_each_difference_against_its_tolerance(tmp_path: Path) -> None:
    page = tmp_path / "show.md"
    done = run_pcmm("results", "show", str(QIF_SAMPLE), "--report", str(page), "--json", *WHO)
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    tables = markdown_tables(page)
    characteristics = next(rows for title, rows in tables.items() if title.startswith("Characteristics"))
    assert [int(row[0]) for row in characteristics[1:]] == [c["id"] for c in data["characteristics"]]
    plot = tmp_path / "v.png"
    done = run_pcmm("qif", "verify", str(QIF_SAMPLE), "--plot", str(plot), "--json")
    assert done.returncode == 1 and plot.stat().st_size > 10_000
    from pcmm_geo.cmm.verify import verify_document
    from pcmm_geo.io.cmm import read_qif
    from pcmm_geo.plots.cmm_verify import verification_ratios

    ratios = verification_ratios(verify_document(read_qif(QIF_SAMPLE)))
    features = {f["id"]: f for f in json.loads(done.stdout)["features"]}
    # the plane's location: 1.7909 µm against 0.1 µm; the single points: the probe radius 2.49978 mm
    assert ("11 DATUMA", "location", pytest.approx(features[11]["difference"]["location_distance_mm"] / 1e-4)) in [
        (label, name, ratio) for label, name, ratio in ratios]
    assert sum(ratio > 1 for _, _, ratio in ratios) == 6  # DATUMA location, direction and 4 points
    refused = run_pcmm("qif", "verify", str(QIF_SAMPLE), "--plot", str(plot))
    assert refused.returncode == 2 and "already exists" in refused.stderr


def test_iso10360_6_report_lists_every_case_and_the_mpes(tmp_path: Path) -> None:
    page = tmp_path / "s.md"
    done = run_pcmm("iso10360-6", str(EXAMPLES / "iso10360_6_reference.csv"), str(EXAMPLES / "iso10360_6_results.json"),
                    "--mpe-size-mm", "2e-7", "--report", str(page), "--json", *WHO)
    data = json.loads(done.stdout)
    tables = markdown_tables(page)
    cases = {row[0]: row for row in tables["ISO 10360-6 software test"][1:]}
    assert sorted(cases) == sorted(c["name"] for c in data["cases"]) and len(cases) == data["n_cases"]
    for case in data["cases"]:
        assert cases[case["name"]][6].startswith("pass" if case["passed"] else "FAIL")
    mpes = {row[0]: float(row[1]) for row in tables["Maximum permissible errors of the test"][1:]}
    assert mpes == {"position": 1e-9, "orientation": 1e-9, "size": 2e-7, "angle": 1e-9}
    assert done.returncode == (0 if data["passed"] else 1)


def test_an_overwritten_output_is_not_listed_as_an_input(tmp_path: Path) -> None:
    page, plot = tmp_path / "r.md", tmp_path / "p.png"
    for _ in range(2):  # the second run replaces both files, which then exist when the inputs are hashed
        done = run_pcmm("iso10360-5", str(SPHERE), "--report", str(page), "--plot", str(plot), "--overwrite", *WHO)
        assert done.returncode == 0, done.stderr
    inputs = [row[0] for row in markdown_tables(page)["Inputs"][1:]]
    assert inputs == [str(SPHERE)]
