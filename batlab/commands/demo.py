"""`batlab demo`: the whole lab workflow on the virtual rig, no hardware and no input files.

The built-in bat (``batlab/builtin/``: a smooth 34 in pro-style ash profile and its meta.json)
is tested on the virtual rig as the real board would behave (4 % stiffer and 3 % lighter than
the handbook, E/G = 13, Timoshenko, 3 g accelerometer, bungees, 0.5 % noise). Its baseline is
registered; weeks later it is re-tested after moisture moved (+0.8 points), the accelerometer
was re-mounted 0.05 in away, and someone corked it (1 in core, 10 in deep, 1 in plug, fill
0.3 of the wood's density). The re-test is inspected against the registry and reported.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

from batlab.cli_support import add_db_argument, progress_printer

HELP = "simulate a baseline and a corked re-test of a built-in bat, register and inspect them"
EXAMPLE = "batlab demo --out demo/"

TRUTH = {"E_scale": 1.04, "density_scale": 0.97, "e_over_g": 13.0, "sensor_mass_g": 3.0,
         "bungee_k_n_per_m": 150.0, "noise_pct": 0.5, "df_hz": 1.0, "fmax_hz": 3200.0}
RETEST = {"alteration": "cork:depth=10,d=1.0,ratio=0.3,plug=1", "moisture_pct": 0.8,
          "sensor_offset_in": 0.05}


def add_arguments(p) -> None:
    p.add_argument("--out", default=None,
                   help="work directory for the test files, registry and report (default: a "
                        "new temporary directory)")
    add_db_argument(p)
    p.add_argument("--seed", type=int, default=7, help="noise seed of the baseline (re-test: +1)")
    p.add_argument("--json", action="store_true", help="print the verdict JSON on stdout")


def builtin_dir() -> Path:
    """The built-in bat's files (package data)."""
    return Path(__file__).resolve().parent.parent / "builtin"


def simulate_pair(work: Path, seed: int, progress,
                  alteration: str | None = RETEST["alteration"]) -> tuple[Path, Path, Path, Path]:
    """Copy the built-in bat to ``work`` and write its baseline and re-test as UFF (the re-test
    after moisture and a re-mounted sensor, and ``alteration`` unless None)."""
    import numpy as np

    from ema.io.frf_io import write_test
    from updating.model.lab_input import parse_core_spec, read_meta
    from updating.model.material import Material
    from updating.model.profile import read_profile_csv
    from updating.model.units import IN_TO_M
    from updating.simulate.virtual_bat import VirtualBat, simulate_test, with_changes

    profile_path, meta_path = work / "profile.csv", work / "meta.json"
    for src, dst in ((builtin_dir() / "profile.csv", profile_path),
                     (builtin_dir() / "meta.json", meta_path)):
        shutil.copyfile(src, dst)
    profile, meta = read_profile_csv(profile_path), read_meta(meta_path)
    wood = meta.material.scaled(TRUTH["E_scale"], TRUTH["density_scale"])
    bat = VirtualBat(profile, Material(wood.E_pa, wood.rho_kg_m3, TRUTH["e_over_g"], wood.nu),
                     np.sort(meta.points_m), sensor_mass_kg=TRUTH["sensor_mass_g"] / 1000,
                     bungee_k_n_per_m=TRUTH["bungee_k_n_per_m"],
                     rel_noise=TRUTH["noise_pct"] / 100)
    freq = np.arange(0.0, TRUTH["fmax_hz"] + TRUTH["df_hz"] / 2, TRUTH["df_hz"])
    core = None if alteration is None else parse_core_spec(alteration)
    retest_bat = with_changes(bat, core=core,
                              moisture_pct=RETEST["moisture_pct"],
                              sensor_offset_m=RETEST["sensor_offset_in"] * IN_TO_M)
    baseline_path, retest_path = work / "baseline.uff", work / "retest.uff"
    progress(f"simulating the baseline test of {meta.serial} on the virtual rig")
    write_test(baseline_path, simulate_test(bat, freq, seed=seed))
    progress("simulating the re-test weeks later: moisture +0.8 points, accelerometer "
             "re-mounted" + ("" if alteration is None else f", altered ({alteration})"))
    write_test(retest_path, simulate_test(retest_bat, freq, seed=seed + 1))
    return profile_path, meta_path, baseline_path, retest_path


def run(args) -> int:
    from batlab import pipeline
    from batlab.formatting import readable
    from batlab.registry import open_registry
    from batlab.report import check_destination, write_report

    progress = progress_printer("demo")
    work = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="batlab-demo-"))
    check_destination(work, "--out")
    db = Path(args.db) if args.db else work / "registry.sqlite"
    profile, meta, baseline, retest = simulate_pair(work, args.seed, progress)
    with open_registry(db) as conn:
        done = pipeline.register_files(conn, profile, meta, baseline, replace=True,
                                       progress=progress)
        serial = done.record.serial
        result = pipeline.inspect_registered(conn, serial, retest, refit_baseline=True,
                                             progress=progress, baseline_fit=done.baseline.fit)
        stored = pipeline.store_inspection(conn, result, retest)
        inputs = pipeline.report_inputs(result, done.record.meta,
                                        pipeline.provenance(conn, stored=stored))
        report = write_report(work / "report", inputs)
        pipeline.note_report(conn, stored, str(report))
    out = pipeline.contract_dict(serial, result.verdict)
    progress(f"wrote the tests, registry and report under {work}; report: {report}")
    if args.json:
        print(json.dumps(out), flush=True)
    else:
        print(readable(out))
        print(f"truth: corked, 1.00 in core from 24.0 to 33.0 in, fill 0.30 "
              f"(plus moisture +{RETEST['moisture_pct']} points and a re-mounted sensor)")
        print(f"report: {report}")
        print(f"files:  {work} (profile.csv, meta.json, baseline.uff, retest.uff); "
              f"registry: {db}")
        print(f"again:  batlab inspect --serial {serial} {retest} --db {db}")
    return 0
