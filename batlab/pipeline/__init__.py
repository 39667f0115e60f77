"""The one seam between batlab's commands and the stages (``rigs``, ``ema``, ``updating``).

A command (``batlab/commands/<name>.py``) parses its arguments, calls the functions here
with explicit arguments, and prints what they return (``batlab.formatting`` words it); it
imports no stage module itself (tests/test_architecture.py checks it). One module per job:

- ``inspection``: files to verdict -- read and fit FRF files, diagnose a baseline, check a
  rig, register and inspect bats, the contract's JSON, stored inspections, export.
- ``bench``: the test bench -- a bat's wood, FE model and pre-test summary, tests on the
  virtual rig (one test, a nuisance-rich field case, the demo's pair, the rig's modal model).
- ``paper``: the paper's corked-bat case (SEREP + MSSO, the refinement, Figures 2 and 3).
- ``acquisition``: the acquisition box's driver and session, the session's files, the FRF
  file written at the end.

The unit constants the commands convert lab units with at the edge are re-exported here.
"""

from batlab.pipeline.acquisition import (
    DEFAULT_POINTS_IN,
    CaptureSettings,
    ReplaySource,
    SerialDevice,
    SessionInterrupted,
    combine,
    device_info_from_dict,
    load_points,
    open_port,
    run_session,
    save_points,
    write_json_atomic,
    write_session_test,
)
from batlab.pipeline.bench import (
    DEMO_RETEST,
    FAULTS,
    BoxConfig,
    DemoFiles,
    VirtualBox,
    bat_modal_model,
    bat_model,
    bat_profile,
    default_info,
    meta_points_m,
    nuisance_names,
    simulate_bat_test,
    simulate_demo_pair,
    simulate_field_case,
    summarise_model,
    uniform_beam_model,
    virtual_bat,
    wood,
    write_frf,
)
from batlab.pipeline.inspection import (
    MIN_SNR,
    FittedTest,
    InspectionResult,
    Registration,
    ReportInputs,
    calibrate,
    check_rig_files,
    contract_dict,
    diagnose_files,
    file_sha256,
    fit_file,
    fit_modes,
    fit_test_file,
    history_table,
    inspect_files,
    inspect_modes,
    inspect_registered,
    jsonable,
    match_points,
    note_report,
    plot_fit_files,
    point_positions_m,
    provenance,
    read_bat_files,
    read_conditions,
    read_frf,
    read_meta_dict,
    read_test_file,
    register_files,
    reorder,
    report_inputs,
    sensor_x_m,
    store_inspection,
    stored_bat,
    stored_report_inputs,
    verdict_record,
    write_csv,
    write_modes_file,
)
from batlab.pipeline.paper import (
    PAPER,
    TRUE,
    PaperCase,
    element_rows,
    plot_figures,
    run_paper_case,
)
from updating.model.json_input import read_json_object
from updating.model.units import (
    IN_TO_M,
    KG_M2_TO_LB_IN2,
    LB_TO_KG,
    LBF_IN3_TO_KG_M3,
    PSI_TO_PA,
)

__all__ = [
    "BoxConfig", "CaptureSettings", "DEFAULT_POINTS_IN", "DEMO_RETEST", "DemoFiles", "FAULTS",
    "FittedTest", "IN_TO_M", "InspectionResult", "KG_M2_TO_LB_IN2", "LBF_IN3_TO_KG_M3",
    "LB_TO_KG", "MIN_SNR", "PAPER", "PSI_TO_PA", "PaperCase", "Registration", "ReplaySource",
    "ReportInputs", "SerialDevice", "SessionInterrupted", "TRUE", "VirtualBox",
    "bat_modal_model", "bat_model", "bat_profile", "calibrate", "check_rig_files", "combine",
    "contract_dict", "default_info", "device_info_from_dict", "diagnose_files", "element_rows",
    "file_sha256", "fit_file", "fit_modes", "fit_test_file", "history_table", "inspect_files",
    "inspect_modes", "inspect_registered", "jsonable", "load_points", "match_points",
    "meta_points_m", "note_report", "nuisance_names", "open_port", "plot_figures",
    "plot_fit_files", "point_positions_m", "provenance", "read_bat_files", "read_conditions",
    "read_frf", "read_json_object", "read_meta_dict", "read_test_file", "register_files", "reorder",
    "report_inputs", "run_paper_case", "run_session", "save_points", "sensor_x_m",
    "simulate_bat_test", "simulate_demo_pair", "simulate_field_case", "store_inspection",
    "stored_bat", "stored_report_inputs", "summarise_model", "uniform_beam_model",
    "verdict_record", "virtual_bat", "wood", "write_csv", "write_frf", "write_json_atomic",
    "write_modes_file", "write_session_test",
]
