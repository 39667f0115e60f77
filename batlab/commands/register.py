"""`batlab register`: a new bat's baseline into the registry (fit, calibrate, store)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from batlab.cli_support import add_db_argument, db_path, note_printer, progress_printer

EXAMPLE = "batlab register --profile profile.csv --meta meta.json --baseline baseline.uff"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab register`` to its sub-parser."""
    p.add_argument("--serial", default=None, help="serial number (default: meta.json's; must "
                                                  "agree with it)")
    p.add_argument("--profile", required=True, help="profile.csv (x_in,diameter_in)")
    p.add_argument("--meta", required=True, help="meta.json")
    p.add_argument("--baseline", required=True, help="baseline test (.uff, .csv or .npz)")
    p.add_argument("--replace", action="store_true",
                   help="replace an already registered bat (its inspections are kept)")
    p.add_argument("--force", action="store_true",
                   help="register a baseline the after-fit checks find odd (calibration "
                        "outside the species' range, misfit, mass line off the weight), for a "
                        "real bat that odd only; the record and every report say so (unit "
                        "slips in the files are still refused)")
    add_db_argument(p)
    p.add_argument("--json", action="store_true", help="print JSON on stdout")


def run(args: argparse.Namespace) -> int:
    """Register a bat: fit its baseline, calibrate its reference, store it.

    Parameters
    ----------
    args : argparse.Namespace
        The options ``add_arguments`` defines.

    Returns
    -------
    int
        Exit code: 0 (bad input raises ValueError or OSError; ``batlab.cli`` prints
        it in one line and exits 2).
    """
    from batlab.pipeline import (
        LBF_IN3_TO_KG_M3,
        PSI_TO_PA,
        admit,
        prepare_registration,
        require_unregistered,
        store_registration,
    )
    from batlab.registry import is_url, open_registry, shown

    progress = progress_printer("register")
    path = db_path(args)
    meta = admit(args, note_printer("register"), registry=path, create=True)["meta"]
    if is_url(path) or Path(path).is_file():  # fail fast, before the fit (damaged, registered)
        with open_registry(path) as conn:
            if not args.replace:
                require_unregistered(conn, meta.serial)
    prepared = prepare_registration(args.profile, args.meta, args.baseline, args.serial,
                                    progress, force=args.force)
    with open_registry(path) as conn:
        done = store_registration(conn, prepared, args.baseline, args.replace, progress)
    rec = done.record
    out = {"serial": rec.serial, "db": shown(path), "registered_at": rec.registered_at,
           "baseline": rec.baseline_name, "baseline_sha256": rec.baseline_sha256,
           "modes_hz": [round(f, 3) for f in rec.modes["freq_hz"]],
           "reference": rec.reference}
    if args.json:
        print(json.dumps(out))
    else:
        print(f"registered {rec.serial} in {shown(path)}")
        print(f"  baseline {rec.baseline_name} (sha256 {rec.baseline_sha256[:16]}...)")
        print("  modes (Hz): " + ", ".join(f"{f:.1f}" for f in rec.modes["freq_hz"]))
        ref = rec.reference
        print(f"  calibrated: E {ref['E_pa'] / PSI_TO_PA:,.0f} psi, weight density "
              f"{ref['rho_kg_m3'] / LBF_IN3_TO_KG_M3:.5f} lbf/in^3, E/G {ref['e_over_g']:.1f}, "
              f"{ref['beam']} beam")
    return 0
