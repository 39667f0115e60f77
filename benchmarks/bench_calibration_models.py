"""How far one calibration carries: clean re-tests of several bat models side by side.

Calibrates five bat models (31-34 in; white ash, sugar maple, yellow birch; the built-in
profile and four drawn pro-style profiles, ``updating.simulate.fleet.pro_profile`` stretched
to the model's length, with 0.003 in caliper noise on the lab's copy), each with ``batlab
fleet calibrate`` as a league runs it (the real command line, a local Dask cluster), then
tabulates per model: n, called altered, inconclusive, the false-alarm rate's 95 % bound, F's
clean quantiles (50/90/99 %, the largest) and the share of F above the floor of 9, the
core-seconds a bat, and a two-sample Kolmogorov-Smirnov p-value of the model's F against the
other models' pooled F (small: that model's null differs). Rows are kept in OUT/MODEL.rows.jsonl
and every run is ``--resume``d, so a stopped study goes on and the table can be printed again
from the rows alone (``--table``).

    nice -n 10 python benchmarks/bench_calibration_models.py --n 60 --out /tmp/models \
        [--db /tmp/models/registry.sqlite] [--seed 2026] [--table]

With ``--db`` each calibration is also stored (``--store --model NAME``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from updating.model.assembly import build_model  # noqa: E402
from updating.model.mass_properties import mass_properties  # noqa: E402
from updating.model.material import material_from_imperial  # noqa: E402
from updating.model.profile import Profile, read_profile_csv, write_profile_csv  # noqa: E402
from updating.model.units import IN_TO_M, LB_TO_KG  # noqa: E402
from updating.simulate.fleet import SPECIES, pro_profile  # noqa: E402

BUILTIN = ROOT / "batlab" / "builtin"


@dataclass(frozen=True)
class Model:
    """A bat model: its name, species, length and profile draw (None: the built-in)."""

    name: str
    species: str
    length_in: float
    profile_seed: int | None


MODELS = (
    Model("ash-34-builtin", "white ash", 34.0, None),
    Model("maple-33-a", "sugar maple", 33.0, 101),
    Model("birch-32-a", "yellow birch", 32.0, 102),
    Model("ash-31-a", "white ash", 31.0, 103),
    Model("maple-34-b", "sugar maple", 34.0, 104),
)


def model_profile(m: Model) -> Profile:
    """The lab's caliper profile of a model: the built-in, or a drawn one at its length."""
    if m.profile_seed is None:
        return read_profile_csv(BUILTIN / "profile.csv")
    rng = np.random.default_rng(m.profile_seed)
    drawn = pro_profile(rng)
    x = drawn.x_m * (m.length_in * IN_TO_M / drawn.length_m)
    d = drawn.diameter_m + 0.003 * IN_TO_M * rng.standard_normal(x.size)
    return Profile(x, d)


def write_model(m: Model, folder: Path) -> tuple[Path, Path]:
    """Write a model's profile.csv and meta.json (handbook wood, its weight, points)."""
    folder.mkdir(parents=True, exist_ok=True)
    profile_path, meta_path = folder / "profile.csv", folder / "meta.json"
    if m.profile_seed is None:
        profile_path.write_text((BUILTIN / "profile.csv").read_text())
        meta = json.loads((BUILTIN / "meta.json").read_text())
    else:
        profile = model_profile(m)
        write_profile_csv(profile_path, profile)
        E_psi, wd = SPECIES[m.species]
        bare = build_model(profile, material_from_imperial(E_psi, wd), beam="timoshenko",
                           element_length_m=0.5 * IN_TO_M)
        L_in = profile.length_m / IN_TO_M
        points = np.append(np.arange(1.0, L_in - 1.5, 2.0), round(L_in - 1.0, 2))
        meta = {"serial": m.name.upper(), "species": m.species, "nominal_E_psi": E_psi,
                "nominal_weight_density_lbf_in3": round(wd, 5),
                "weight_lb": round(mass_properties(bare).mass_kg / LB_TO_KG, 4),
                "points_in": [round(float(x), 3) for x in points]}
    meta_path.write_text(json.dumps(meta, indent=1))
    return profile_path, meta_path


def calibrate(m: Model, out: Path, n: int, seed: int, db: str | None) -> dict:
    """Run ``batlab fleet calibrate`` on a model (resumed from its rows file)."""
    profile_path, meta_path = write_model(m, out / m.name)
    argv = [sys.executable, "-m", "batlab", "fleet", "calibrate", "--profile", str(profile_path),
            "--meta", str(meta_path), "--n", str(n), "--seed", str(seed),
            "-o", str(out / f"{m.name}.rows.jsonl"), "--resume", "--json"]
    if db:
        argv += ["--store", "--db", db, "--model", m.name]
    res = subprocess.run(argv, capture_output=True, text=True, cwd=ROOT)
    if res.returncode != 0:
        raise SystemExit(f"{m.name}: fleet calibrate failed:\n{res.stderr[-2000:]}")
    (out / f"{m.name}.stderr.txt").write_text(res.stderr)
    return json.loads(res.stdout)


def read_rows(path: Path) -> list[dict]:
    """A rows file's rows, by index."""
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return sorted(rows, key=lambda r: r["index"])


def finite_f(rows: list[dict]) -> np.ndarray:
    return np.array([r["F"] for r in rows if r.get("F") is not None and np.isfinite(r["F"])])


def table(out: Path, models=MODELS) -> str:
    """The side-by-side table of every model's rows in ``out``."""
    from scipy.stats import ks_2samp

    from batlab.fleet.calibrate import upper95

    rows = {m.name: read_rows(out / f"{m.name}.rows.jsonl") for m in models
            if (out / f"{m.name}.rows.jsonl").exists()}
    f = {k: finite_f(v) for k, v in rows.items()}
    lines = ["| model | species | length in | n | called altered | inconclusive | bound 95 % | "
             "F 50 % | F 90 % | F 99 % | F max | F > 9 | KS p vs others | CPU s a bat |",
             "|" + "---|" * 14]
    for m in models:
        if m.name not in rows:
            continue
        r, fm = rows[m.name], f[m.name]
        others = np.concatenate([v for k, v in f.items() if k != m.name] or [np.array([])])
        alarms = sum(x["status"] == "altered" for x in r)
        q = np.quantile(fm, [0.5, 0.9, 0.99]) if fm.size else [np.nan] * 3
        ks = ks_2samp(fm, others).pvalue if fm.size and others.size else np.nan
        cpu = [x["cpu_s"] for x in r if x.get("cpu_s") is not None]
        lines.append(
            f"| {m.name} | {m.species} | {m.length_in:.0f} | {len(r)} | {alarms} | "
            f"{sum(x['status'] == 'inconclusive' for x in r)} | {upper95(alarms, len(r)):.3f} | "
            f"{q[0]:.2f} | {q[1]:.2f} | {q[2]:.2f} | {fm.max() if fm.size else np.nan:.2f} | "
            f"{int((fm > 9).sum())} | {ks:.2g} | {np.mean(cpu) if cpu else np.nan:.2f} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=60, help="clean re-tests per model (default 60)")
    ap.add_argument("--seed", type=int, default=2026, help="the study's seed (default 2026)")
    ap.add_argument("--out", type=Path, required=True, help="folder of the models and rows")
    ap.add_argument("--db", default=None, help="also store each calibration in this registry")
    ap.add_argument("--table", action="store_true", help="only print the table of OUT's rows")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if not args.table:
        for m in MODELS:
            out = calibrate(m, args.out, args.n, args.seed, args.db)
            cost = out.get("core_s_per_bat")
            print(f"{m.name}: n {out['n']}, called altered {out['false_alarms']}, "
                  f"inconclusive {out['inconclusive']}, bound {out['false_alarm_upper95']:.3g}"
                  + ("" if cost is None else f", {cost:.2f} core-s a bat"), flush=True)
    print(table(args.out))


if __name__ == "__main__":
    main()
