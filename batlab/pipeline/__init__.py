"""The one seam between batlab's commands and the stages (``rigs``, ``ema``, ``updating``).

A command (``batlab/commands/<name>.py``) parses its arguments, calls the functions here
with explicit arguments, and prints what they return (``batlab.formatting`` words it); it
imports no stage module itself (tests/test_architecture.py checks it). One module per job:

- ``door``: a command's options, input files and outputs checked before any work
  (``admit``).
- ``files``: the lab's files in and out (FRF tests, profile.csv, meta.json, retest.json,
  CSV).
- ``modal``: `batlab fit` -- a test's modal analysis, its modes file and figures.
- ``records``: the fitted tests, a report's inputs and the contract's JSON (light: the
  report imports it without the stages).
- ``chance``: a bat's model, and its verdict's chance and false-alarm rate as measured on
  the model's stored calibration (or said unmeasured).
- ``inspection``: files to verdict -- a bat's inputs read once (``InspectionCase``), then
  the method's one call (``judge``); the stateless form.
- ``registered``: register a bat, inspect a re-test against it.
- ``stored``: an inspection stored, and read back -- provenance, report inputs, export.
- ``diagnosis``: a baseline against the nominal model, a rig's reference bar.
- ``bench``: the test bench -- a bat's wood, FE model and pre-test summary, tests on the
  virtual rig (one test, a nuisance-rich field case, the demo's pair, the rig's modal model).
- ``paper``: the paper's corked-bat case (SEREP + MSSO, the refinement, Figures 2 and 3).
- ``acquisition``: the acquisition box's driver and session, the session's files, the FRF
  file written at the end.

Names are loaded on first use (PEP 562), so importing one light module of the package
loads no stage. The unit constants the commands convert lab units with at the edge, and the
running code's version (``batlab.version.code_version``, for the fleet's rows), are
re-exported here.
"""

from __future__ import annotations

import importlib

_SOURCES = {
    "batlab.pipeline.acquisition": (
        "CaptureSettings", "DEFAULT_POINTS_IN", "ReplaySource", "SerialDevice",
        "SessionInterrupted", "combine", "device_info_from_dict", "load_points", "open_port",
        "run_session", "save_points", "write_json_atomic", "write_session_test",
    ),
    "batlab.pipeline.bench": (
        "BoxConfig", "DEMO_RETEST", "DemoFiles", "FAULTS", "VirtualBox", "bat_modal_model",
        "bat_model", "bat_profile", "default_info", "meta_points_m", "nuisance_names",
        "simulate_bat_test", "simulate_demo_pair", "simulate_field_case", "summarise_model",
        "uniform_beam_model", "virtual_bat", "wood", "write_frf",
    ),
    "batlab.pipeline.chance": (
        "model_name", "result_dict", "statement", "with_statement",
    ),
    "batlab.pipeline.diagnosis": (
        "check_rig_files", "diagnose_files",
    ),
    "batlab.pipeline.door": (
        "admit", "check_output", "check_registry",
    ),
    "batlab.pipeline.files": (
        "file_sha256", "read_bat_files", "read_conditions", "read_frf", "read_meta_dict",
        "write_csv",
    ),
    "batlab.pipeline.modal": (
        "MIN_SNR", "fit_test_file", "plot_fit_files", "write_modes_file",
    ),
    "batlab.pipeline.inspection": (
        "InspectionCase", "InspectionResult", "calibrate_baseline", "fit_file",
        "inspect_files", "judge", "stateless_case",
    ),
    "batlab.pipeline.paper": (
        "PAPER", "PaperCase", "TRUE", "element_rows", "plot_figures", "run_paper_case",
    ),
    "batlab.pipeline.records": (
        "FittedTest", "ReportInputs", "contract_dict", "jsonable", "stored_contract_dict",
        "verdict_record",
    ),
    "batlab.pipeline.registered": (
        "Registration", "inspect_registered", "prepare_registration", "register_files",
        "registered_case", "require_unregistered", "store_registration",
    ),
    "batlab.pipeline.stored": (
        "already_inspected", "history_table", "note_report", "provenance", "report_inputs",
        "store_inspection", "stored_bat", "stored_report_inputs",
    ),
    "batlab.version": (
        "code_version",
    ),
    "updating.model.json_input": (
        "read_json_object",
    ),
    "updating.model.units": (
        "IN_TO_M", "KG_M2_TO_LB_IN2", "LBF_IN3_TO_KG_M3", "LB_TO_KG", "PSI_TO_PA",
    ),
}
"""The module each public name is defined in."""

_WHERE = {name: module for module, names in _SOURCES.items() for name in names}
_SUBMODULES = ("acquisition", "bench", "chance", "diagnosis", "door", "files", "inspection",
               "modal", "paper", "records", "registered", "stored")

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    """Load a public name (or a sub-module) on first use."""
    if name in _WHERE:
        value = getattr(importlib.import_module(_WHERE[name]), name)
    elif name in _SUBMODULES:
        value = importlib.import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """List the public names and sub-modules."""
    return sorted(set(globals()) | set(_WHERE) | set(_SUBMODULES))
