"""`batlab simulate`: a roving-hammer test of a bat on the virtual rig, written as a UFF file."""

from __future__ import annotations

import argparse
import json
import sys

from batlab.cli_support import add_deprecated_alias, add_out_argument, progress_printer

EXAMPLE = ("batlab simulate --profile profile.csv --meta meta.json \\\n"
           "      --alter cork:depth=10,d=1.0 --seed 1 -o retest.uff")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab simulate`` to its sub-parser."""
    p.add_argument("--profile", help="profile.csv (default: the paper's bat)")
    p.add_argument("--meta", help="meta.json: wood and test points (default: the paper's white "
                                  "birch, said on stderr)")
    add_out_argument(p, "the test file to write (.uff, .csv or .npz), or with --case the "
                        "folder", "PATH")
    p.add_argument("--case", nargs="?", const=True, default=False, metavar="DIR",
                   help="instead of one test: a random nuisance-rich bat as a lab hands it over "
                        "(profile.csv, meta.json, baseline.uff, retest.uff, retest.json, "
                        "truth.json) in the folder -o; see --kind, --nuisances, --integrity, "
                        "--seed (--case DIR: deprecated, use --case -o DIR)")
    p.add_argument("--kind", default="none",
                   help="--case: alteration of the re-test, one of the simulator's kinds "
                        "(none, a core such as cork, or a rulebook kind such as nails or "
                        "flattened); an unknown name is refused with the whole list")
    p.add_argument("--calipers", type=int, default=0, metavar="N",
                   help="--case: also the re-test's caliper profile read at N orientations "
                        "(retest_profile.csv; 4: 0, 45, 90, 135 deg)")
    p.add_argument("--records", type=int, default=None, metavar="N",
                   help="--case: what the lab records of the wood and the room at both tests "
                        "(tested_on, humidity_pct, conditioned_h, and N moisture meter "
                        "readings at each of the handle, mid-barrel and barrel end; 0: no "
                        "readings) in retest.json and meta.json (which then also holds the "
                        "baseline's temperature and accelerometer mass)")
    p.add_argument("--nuisances", default="all",
                   help="--case: all, none, or a comma-separated list (moisture, uniform_drift, "
                        "temperature, billet, planes, cup, noise, points, model_points, band, "
                        "accelerometer, bungees)")
    p.add_argument("--integrity", default=None,
                   help="--case: a data-integrity slip of the re-test: receptance_as_accelerance,"
                        " g_per_n_as_si, other_bat, no_barrel_points")
    p.add_argument("--alter", default=None,
                   help="alteration, inches: cork|heavy|neutral|core:depth=10,d=1.0,ratio=0.33")
    p.add_argument("--moisture", type=float, default=0.0,
                   help="moisture-content change, percentage points (E -2 %%, mass +1 %% each)")
    p.add_argument("--seed", type=int, default=None, help="noise seed (reproducible)")
    add_deprecated_alias(p, "--points", "--points-in", "points_in")
    p.add_argument("--points-in", default=None,
                   help="impact points, inches from the knob, comma-separated (default: meta's "
                        "points_in, else every 2 in)")
    p.add_argument("--e-over-g", type=float, default=None,
                   help="the wood's E/G (default 14, as model and rig)")
    p.add_argument("--E-scale", type=float, default=1.0,
                   help="true modulus / nominal modulus (board-to-board variation)")
    p.add_argument("--density-scale", type=float, default=1.0,
                   help="true density / nominal density")
    p.add_argument("--beam", choices=("euler", "timoshenko"), default="timoshenko",
                   help="beam theory of the simulated bat (default timoshenko: a real bat "
                        "shears)")
    p.add_argument("--sensor-mass-g", type=float, default=3.0, help="accelerometer mass, g")
    p.add_argument("--sensor-offset-in", type=float, default=0.0,
                   help="accelerometer distance from its labelled point, in")
    p.add_argument("--bungee-k", type=float, default=150.0,
                   help="stiffness of each of the two bungees, N/m (0: truly free)")
    p.add_argument("--noise-pct", type=float, default=0.5, help="multiplicative FRF noise, %%")
    p.add_argument("--zeta", type=float, default=0.005, help="first-mode damping ratio")
    p.add_argument("--df", type=float, default=0.5, help="frequency resolution, Hz")
    p.add_argument("--fmax", type=float, default=3200.0, help="highest frequency line, Hz")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")


def run_case(args, folder: str) -> int:
    """`--case -o DIR`: one random bat of the nuisance-rich fleet, written as lab files."""
    from batlab import pipeline

    if args.nuisances == "all":
        nuisances = pipeline.nuisance_names()
    elif args.nuisances == "none":
        nuisances = ()
    else:
        nuisances = tuple(n.strip() for n in args.nuisances.split(",") if n.strip())
    paths, expected = pipeline.simulate_field_case(
        args.seed, args.kind, nuisances, args.integrity, folder,
        progress=progress_printer("simulate"), calipers=args.calipers, records=args.records)
    summary = {k: str(v) for k, v in paths.items() if v is not None}
    summary["expected"] = expected
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"wrote {folder}: {', '.join(sorted(summary))}")
    return 0


def run(args: argparse.Namespace) -> int:
    """Simulate an impact test of a bat on the virtual rig and write it.

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
    from batlab import pipeline
    from batlab.cli_support import note_printer

    pipeline.admit(args, note_printer("simulate"), outputs={"out": "dir" if args.case else
                                                            "file"})
    if isinstance(args.case, str):  # the old --case DIR
        print("batlab simulate: warning: --case DIR is deprecated and goes in the next "
              "release: use --case -o DIR", file=sys.stderr)
        if args.out:
            raise ValueError("give --case -o DIR, not both --case DIR and -o")
        return run_case(args, args.case)
    if not args.out:
        raise ValueError("-o/--out is required (a test file, or with --case a folder)")
    if args.case:
        return run_case(args, args.out)
    import numpy as np

    from batlab.pipeline import IN_TO_M

    profile = pipeline.bat_profile(args.profile)
    meta_points_m = pipeline.meta_points_m(args.meta) if args.meta else None
    material = pipeline.wood(args.meta, args.e_over_g, note_printer("simulate")).scaled(
        args.E_scale, args.density_scale)
    if args.points_in:
        try:
            points = np.array([float(v) for v in args.points_in.split(",")]) * IN_TO_M
        except ValueError:
            raise ValueError(f"--points-in {args.points_in!r}: not a comma-separated "
                             "list") from None
    elif meta_points_m is not None and meta_points_m.size:
        points = meta_points_m
    else:
        points = np.arange(1.0, profile.length_m / IN_TO_M, 2.0) * IN_TO_M
    if points.size < 2 or points.min() < 0 or points.max() > profile.length_m:
        raise ValueError("impact points must be at least two, within the bat")
    if args.df <= 0 or args.fmax <= args.df:
        raise ValueError("--df must be positive and below --fmax")
    bat = pipeline.virtual_bat(
        profile, material, np.sort(points), sensor_offset_m=args.sensor_offset_in * IN_TO_M,
        sensor_mass_kg=args.sensor_mass_g / 1000, bungee_k_n_per_m=args.bungee_k,
        beam=args.beam, alter=args.alter, moisture_pct=args.moisture, zeta1=args.zeta,
        rel_noise=args.noise_pct / 100)
    freq = np.arange(0.0, args.fmax + args.df / 2, args.df)
    progress = progress_printer("simulate")
    progress(f"simulating {points.size} impact points, {freq.size} lines")
    test = pipeline.simulate_bat_test(bat, freq, seed=args.seed)
    pipeline.write_frf(args.out, test)
    summary = {"out": str(args.out),
               "points_in": [round(float(x), 4) for x in np.sort(points) / IN_TO_M],
               "driving_point_node": int(test.response_nodes[0]), "lines": int(freq.size)}
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"wrote {args.out}: {points.size} FRFs, driving point node "
              f"{summary['driving_point_node']}")
    return 0
