"""Shared pytest fixtures for pcmm_geo."""

from __future__ import annotations

from pathlib import Path

import pytest

DATA_DIR = Path(__file__).parent / "data"

try:
    from hypothesis import settings
except ImportError:  # a core-only environment without the test extra
    pass
else:
    # no example database in the working tree (.hypothesis/): tests run in parallel workers
    # (pytest-xdist) and every run stands on its own; no deadline: speed is for the benchmarks
    settings.register_profile("pcmm_geo", database=None, deadline=None)
    settings.load_profile("pcmm_geo")


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """Folder of the test data bundled with the repository."""
    return DATA_DIR


# Tests that need an optional dependency, directly or through the library: test module (relative to
# tests/) or "module::test function" -> extra.  They get the marker ``extras``; the full run (./dev test)
# runs every test, the core-only CI run (`pip install .` = numpy + scipy) deselects them with
# ``-m "not extras"``, so a core test that secretly needs an extra fails there.
EXTRAS_NEEDED = {
    "acquisition/test_acq_cli.py": "acquire",
    "acquisition/test_acq_programme.py": "acquire",
    "acquisition/test_acq_repeatable.py::test_pty_transport_still_runs_over_real_pseudo_terminals": "acquire",
    "acquisition/test_acq_plan.py::test_hardware_sessions_command_the_start_too": "acquire",
    "cli/test_bad_input.py::test_bad_file_gives_one_line_naming_it_and_exit_2[compare": "cad",
    "cli/test_bad_input.py::test_bad_file_gives_one_line_naming_it_and_exit_2[fit e57": "e57",
    "acquisition/test_acq_lasers.py": "acquire",
    "acquisition/test_acq_probe.py": "acquire",
    "acquisition/test_acq_session.py": "acquire",
    "acquisition/test_acq_zaber.py": "acquire",
    "artefacts/test_cad.py": "cad",
    "cli/test_cli_compare.py": "cad",
    "cli/test_cli_demo.py": "plots",  # the demo draws its figures
    "cli/test_cli_batch.py": "dask",
    "cli/test_cli_plots.py": "plots",
    "cli/test_cli_records.py": "plots",  # every command's --plot / --report
    "fit/test_scale.py": "dask",
    "fit/test_zone.py::test_mcc_matches_trimesh_minimum_nsphere": "cad",
    "plots/test_fit_residual_maps.py": "plots",
    "io/test_meshes.py": "cad",
    "gdt/test_gdt_profile_mesh.py": "cad",
    "ippdme/test_ippdme_workpieces.py::test_mesh_workpiece_matches_the_box": "cad",
    "ippdme/test_ippdme_drivers.py": "acquire",
    "io/test_lazy_points.py": "dask",
    "cli/test_signals.py::test_an_interrupted_acquisition_keeps_its_rows_and_resumes": "acquire",
    "cli/test_signals.py::test_acquire_overwrite_interrupted_puts_the_old_log_back_beside_the_new_one": "acquire",
    "cli/test_signals.py::test_acquire_overwrite_killed_is_put_right_by_the_next_run": "acquire",
    "io/test_clouds.py::test_binary_clouds_go_through_open3d": "cad",
    "io/test_clouds.py::test_e57_in_metres_read_in_mm_with_pose_and_invalid_points": "e57",
    "io/test_e57.py": "e57",
    "plots/test_plots.py": "plots",
    "plots/test_plot_readability.py": "plots",
    "cli/test_cli_calibrate.py::test_calibrate_text_output_and_files": "plots",
    "cli/test_cli_kinematics.py::test_sensitivity_plot": "plots",
    "cli/test_cli_fit.py::test_fit_circle_projected_matches_nist_and_human_table": "plots",
    "cli/test_cli_form.py::test_form_roundness_pass_and_fail_with_plot": "plots",
    "uncertainty/test_cli_uncertainty.py::test_uncertainty_command_from_a_calibration_file": "plots",
    "io/test_points.py::test_round_trip": "cad",
    "machine/test_sensitivity.py::test_plot_and_errors": "plots",
    "machine/test_logproc.py::test_read_log_accepts_acquisition_logs_with_metadata_and_extra_columns": "acquire",
    "cli/test_cli_outputs.py::test_per_output_overwrite": "plots",
    "cli/test_cli_outputs.py::test_a_failure_while_writing_rolls_every_output_back": "plots",
    "cli/test_cli_repeatability.py::test_repeatability_of_the_printed_tables": "plots",
    "cli/test_cli_repeatability.py::test_laser_ratio_of_the_printed_table": "plots",
    "test_docs.py": "docs",
    "io/cmm/test_qif_read.py": "qif",
    "io/cmm/test_qif_hostile.py": "qif",
    "io/cmm/test_qif_write.py": "qif",
    "io/cmm/test_qif_features.py": "qif",
    "cli/test_cli_qif_features.py": "qif",
    "gdt/test_inspect_qif.py": "qif",
    "io/cmm/test_qif_strict.py": "qif",
    "io/cmm/test_qif_definitions.py": "qif",
    "io/cmm/test_reader_fuzz.py::test_a_mutated_file_is_read_or_refused_with_a_typed_error[qif": "qif",
    "gdt/test_qif_second_opinion.py": "qif",  # the plot test also draws (plots): the full run has every extra
    "gdt/test_qif_characteristics.py::test_counts_on_the_public_samples": "qif",
    "gdt/test_qif_characteristics.py::test_values_recomputed_from_the_actuals": "qif",
    "gdt/test_qif_characteristics.py::test_a_reported_value_changed_by_hand_is_caught": "qif",
    "gdt/test_qif_characteristics.py::test_a_bad_agreement_fraction_is_refused": "qif",
    "machine/test_calibration_inputs.py::test_from_csv_and_the_qif_route_give_the_same_balls": "qif",
    "machine/test_calibration_inputs.py::test_from_qif_names_the_file_and_feature_it_refuses": "qif",
    "gdt/test_gdt_frames_plan.py::test_qif_of_composite_symmetry_and_line_profile_is_schema_valid_and_says_what_it_left_out":
        "qif",
    "gdt/test_gdt_propagation.py::test_point_u_in_a_plan_json_table_qif_and_verdicts": "qif",
    "cli/test_cli_reader_contract.py::test_qif_without_file_units_says_so_and_takes_units": "qif",
    "cli/test_cli_reader_contract.py::test_qif_verify_takes_a_material_side": "qif",
    "cli/test_cli_reader_contract.py::test_qif_validate_never_treats_a_path_as_a_url": "qif",
    "cli/test_cli_reader_contract.py::test_an_unknown_xml_encoding_is_a_file_format_error": "qif",
    "cli/test_cli_reader_contract.py::test_formats_are_told_by_content_and_can_be_stated": "qif",
    "cli/test_cli_reader_contract.py::test_multi_sample_files_name_each_sample_and_status_only_files_are_read": "qif",
    "cli/test_cli_full_reports.py::test_an_overwritten_output_is_not_listed_as_an_input": "plots",
    "acquisition/test_acq_lock_resume.py::test_two_sessions_started_together_never_interleave": "acquire",
    # the schema's presence is checked in the core-only run too; validating needs lxml
    "io/cmm/test_qif_schema.py::test_validates_without_a_schema_dir": "qif",
    "io/cmm/test_qif_schema.py::test_a_doctype_is_refused_before_parsing_with_its_line": "qif",
    "io/cmm/test_qif_schema.py::test_deep_nesting_is_refused_as_hostile": "qif",
    "io/cmm/test_qif_schema.py::test_not_well_formed_is_a_file_format_error_with_the_line": "qif",
    # QIF files need defusedxml (reading) and lxml (validating): the qif extra
    "cli/test_bad_input.py::test_bad_file_gives_one_line_naming_it_and_exit_2[qif": "qif",
    "cli/test_bad_input.py::test_bad_file_gives_one_line_naming_it_and_exit_2[fit qif": "qif",
    "cli/test_bad_input.py::test_bad_file_gives_one_line_naming_it_and_exit_2[form qif": "qif",
    "cli/test_bad_input.py::test_bad_file_gives_one_line_naming_it_and_exit_2[calibrate qif": "qif",
    "cli/test_bad_input.py::test_bad_file_gives_one_line_naming_it_and_exit_2[calibrate feature": "qif",
    "cli/test_bad_input.py::test_hostile_qif_gives_one_line_and_writes_nothing": "qif",
    "cli/test_cli_qif.py": "qif",
    "cli/test_cli_cmm_files.py": "qif",
    "cmm/test_qif_pts_sample.py": "qif",
    "cmm/test_reference_qif.py": "qif",
    "machine/test_calibration_qif.py": "qif",
    # reports, help and the documentation's console blocks (they run QIF, plot and CAD commands)
    "cli/test_cli_full_reports.py::test_qif_verify_report_shows_reported_and_refitted_values_as_an_agreement_check":
        "qif",
    "cli/test_cli_full_reports.py::test_qif_show_writes_a_report_and_verify_draws_each_difference_against_its_tolerance":
        "qif",
    "cli/test_cli_help.py::test_results_is_the_qif_command_under_its_own_name": "qif",
    "cli/test_cli_help.py::test_shell_completion_scripts_complete_commands_actions_and_options": "completion",
    "test_docs_console.py::test_every_console_block_prints_what_the_page_shows": "plots",
}


# Modules with tests of ten seconds and more (quiet 2-core machine): collected first, each module whole (its
# module-scoped fixtures are built once), so that the parallel workers share out the short tests at the end
# rather than one of them finishing a long test alone.
FIRST_MODULES = (
    "test_docs.py",
    "acquisition/test_acq_process.py",
    "acquisition/test_acq_plan.py",
    "uncertainty/test_demo_coverage.py",
    "fit/test_zone_axial.py",
    "fit/test_robustness.py",
    "machine/test_numcal.py",
    "plots/test_plots.py",
    "fit/test_zone.py",
    "cli/test_cli_calibrate.py",
    "cli/test_cli_plots.py",
)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark the tests of :data:`EXTRAS_NEEDED` with ``extras(<extra>)``; put :data:`FIRST_MODULES` first."""
    root = Path(__file__).parent
    rank = {module: k for k, module in enumerate(FIRST_MODULES)}

    def order(item: pytest.Item) -> int:
        path = Path(str(item.path))
        return rank.get(path.relative_to(root).as_posix(), len(rank)) if path.is_relative_to(root) else len(rank)

    items.sort(key=order)  # stable: every module keeps its tests together and in order
    for item in items:
        if not Path(str(item.path)).is_relative_to(root):  # the library's doctests
            continue
        module = Path(str(item.path)).relative_to(root).as_posix()
        function = getattr(item, "originalname", item.name)
        # keys: a module, a test function, or the start of a parametrised test's id ("test[compare")
        extra = EXTRAS_NEEDED.get(f"{module}::{function}") or EXTRAS_NEEDED.get(module) or next(
            (value for key, value in EXTRAS_NEEDED.items()
             if "[" in key and f"{module}::{item.name}".startswith(key)), None)
        if extra is not None:
            item.add_marker(pytest.mark.extras(extra))


def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
    """In the core-only run (``-m "not extras"``) whole modules that need an extra are not even imported
    (a module-level ``importorskip`` would otherwise report a skip for a module that is deselected anyway)."""
    if "not extras" not in (config.getoption("markexpr", "") or ""):
        return None
    try:
        module = collection_path.relative_to(Path(__file__).parent).as_posix()
    except ValueError:
        return None
    return True if module in EXTRAS_NEEDED else None
