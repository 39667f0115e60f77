"""`batlab lab`: set or show the lab profile that reports print in their certificate block."""

from __future__ import annotations

import argparse

EXAMPLE = ('batlab lab --name "Bat Lab" --operator "J. Doe" --hammer "PCB 086C03" '
           "--band 20 3000")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab lab`` to its sub-parser."""
    p.add_argument("--name", help="the laboratory's name")
    p.add_argument("--address", help="its postal address")
    p.add_argument("--operator", help="who runs the tests")
    p.add_argument("--hammer", help="impact hammer (make, model, serial)")
    p.add_argument("--hammer-sensitivity", type=float, metavar="MV_PER_N",
                   dest="hammer_sensitivity_mv_per_n", help="hammer sensitivity, mV/N")
    p.add_argument("--accelerometer", help="accelerometer (make, model, serial)")
    p.add_argument("--accelerometer-sensitivity", type=float, metavar="MV_PER_MS2",
                   dest="accelerometer_sensitivity_mv_per_ms2",
                   help="accelerometer sensitivity, mV/(m/s²)")
    p.add_argument("--band", type=float, nargs=2, metavar=("LOW_HZ", "HIGH_HZ"),
                   dest="band_hz", help="analysis band, Hz")
    p.add_argument("--resolution", type=float, metavar="HZ", dest="resolution_hz",
                   help="frequency resolution, Hz")
    p.add_argument("--averages", type=int, metavar="N", help="hits averaged per point")
    p.add_argument("--json", action="store_true", help="print the profile as JSON")


def run(args: argparse.Namespace) -> int:
    """Merge the given fields into the lab profile (``batlab.lab``) and print it.

    Parameters
    ----------
    args : argparse.Namespace
        The options ``add_arguments`` defines.

    Returns
    -------
    int
        Exit code 0 (a bad profile raises ValueError; ``batlab.cli`` exits 2).
    """
    import json
    import sys

    from batlab.lab import LAB_FIELDS, lab_path, lab_rows, read_lab, write_lab

    given = {k: getattr(args, k) for k in LAB_FIELDS if getattr(args, k, None) is not None}
    if "band_hz" in given:
        given["band_hz"] = list(given["band_hz"])
    if given:
        print(f"batlab lab: wrote {write_lab(given)}", file=sys.stderr)
    lab = read_lab()
    if args.json:
        print(json.dumps(lab or {}))
    elif lab is None:
        print(f"no lab profile at {lab_path()} (set one: {EXAMPLE})")
    else:
        for label, text in lab_rows(lab):
            print(f"{label}: {text}")
    return 0
