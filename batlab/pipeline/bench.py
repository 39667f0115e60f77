"""The test bench behind `model`, `simulate`, `rig serve` and `demo`.

The test-bench operations behind `model`, `simulate`, `rig serve` and `demo`: a bat's wood,
its FE model and pre-test summary, and tests of a bat on the virtual rig.

One default wood for every command that builds or simulates a bat: meta.json's species
values when given, else the stated default, the paper's white birch (E 1.8e6 psi,
0.02167 lbf/in^3), with the same E/G everywhere. The choice is never silent: without a
meta.json the ``note`` callable receives which wood was taken (the commands print it on
stderr).

Stage modules are imported inside the functions (the commands' ``--help`` stays fast).
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rigs.virtual_box import FAULTS as FAULTS  # the virtual box, re-exported for `rig serve`
from rigs.virtual_box import BoxConfig as BoxConfig
from rigs.virtual_box import VirtualBox as VirtualBox
from rigs.virtual_box import default_info as default_info
from updating.model.units import IN_TO_M, KG_M2_TO_LB_IN2, LB_TO_KG, LBF_IN3_TO_KG_M3, PSI_TO_PA

__all__ = [
    "BoxConfig", "DEMO_RETEST", "DemoFiles", "FAULTS", "VirtualBox", "bat_modal_model",
    "bat_model", "bat_profile", "default_info", "meta_points_m", "nuisance_names",
    "simulate_bat_test", "simulate_demo_pair", "simulate_field_case", "summarise_model",
    "uniform_beam_model", "virtual_bat", "wood", "write_frf",
]


if TYPE_CHECKING:  # option types only; the stage modules load inside the functions
    from updating.model.assembly import Beam
    from updating.simulate.field_fleet import FieldKind
    from updating.simulate.integrity import Integrity

Progress = Callable[[str], None]

DEFAULT_E_OVER_G = 14.0
"""E/G of a typical bat wood (ash, maple, birch: 9-16 along the grain). Only Timoshenko
models use it; the Euler-Bernoulli model ignores shear."""


def _quiet(_: str) -> None:
    return None


# --- wood, profile, model --------------------------------------------------------------------


def describe_wood(material, e_over_g: float) -> str:
    """"E 1,800,000 psi, 0.02167 lbf/in^3, E/G 14" (lab units)."""
    return (f"E {material.E_pa / PSI_TO_PA:,.0f} psi, {material.rho_kg_m3 / LBF_IN3_TO_KG_M3:.5f}"
            f" lbf/in^3, E/G {e_over_g:g}")


def wood(meta_path: str | None, e_over_g: float | None, note: Progress = _quiet):
    """Return a bat's ``Material``.

    The ``Material`` of a bat: meta.json's (``read_meta``) or the paper's birch, with
    ``e_over_g`` (default DEFAULT_E_OVER_G); ``note`` receives which default was taken.
    """
    from updating.model.lab_input import read_meta
    from updating.model.material import Material, paper_material

    g = DEFAULT_E_OVER_G if e_over_g is None else float(e_over_g)
    if g <= 0:
        raise ValueError(f"--e-over-g {e_over_g}: must be positive")
    if meta_path:
        return read_meta(meta_path, g).material
    base = paper_material()
    material = Material(base.E_pa, base.rho_kg_m3, g, base.nu)
    note(f"no --meta: the default wood, the paper's white birch ({describe_wood(material, g)})")
    return material


def bat_profile(profile_path: str | None):
    """profile.csv (x_in,diameter_in) as a ``Profile``; None: the paper's bat."""
    from updating.model.profile import paper_profile, read_profile_csv

    return read_profile_csv(profile_path) if profile_path else paper_profile()


def meta_points_m(meta_path) -> np.ndarray:
    """meta.json's test points, m from the knob end (empty when it lists none)."""
    from updating.model.lab_input import read_meta

    return read_meta(meta_path).points_m


def core_spec(alter: str | None):
    """Parse an alteration spec into a ``Core``.

    An alteration spec (``cork:depth=10,d=1.0,ratio=0.33,plug=1``, inches) as a ``Core``;
    None stays None.
    """
    from updating.model.lab_input import parse_core_spec

    return parse_core_spec(alter) if alter else None


def bat_model(profile, material, beam: Beam = "euler", rotary_inertia: bool | None = None,
              n_elements: int | None = None, alter: str | None = None):
    """Build the bat's FE model (``updating.model.assembly.build_model``), ``alter``ed if given."""
    from updating.model.assembly import build_model

    return build_model(profile, material, beam=beam, rotary_inertia=rotary_inertia,
                       n_elements=n_elements, core=core_spec(alter))


def summarise_model(model, n_modes: int = 8, n_points: int = 16) -> dict:
    """Summarise a bat's model as `batlab model` prints it.

    The pre-test summary `batlab model` prints, lab units: ndof, weight, centre of mass,
    inertias, the lowest frequencies and the suggested test points (barrel row plus EfI,
    ``updating.model.placement.suggest_points``).
    """
    from updating.model.assembly import displacement_at
    from updating.model.mass_properties import mass_properties
    from updating.model.modes import model_modes
    from updating.model.placement import suggest_points
    from updating.model.units import m_to_in

    mp = mass_properties(model)
    modes = model_modes(model, n_modes=min(n_modes, model.n_dof))
    elastic = modes.elastic()
    targets = elastic.shapes[:, : min(4, elastic.freq_hz.size)]
    layout = suggest_points(model.node_x_m[-1], lambda x: displacement_at(model, targets, x),
                            n_points, targets.shape[1])
    return {
        "ndof": model.n_dof,
        "n_elements": model.n_elements,
        "beam": model.beam,
        "weight_lb": mp.mass_kg / LB_TO_KG,
        "cg_in": m_to_in(mp.cg_m),
        "moi_knob_lb_in2": mp.i_knob_kg_m2 * KG_M2_TO_LB_IN2,
        "moi_cg_lb_in2": mp.i_cg_kg_m2 * KG_M2_TO_LB_IN2,
        "frequencies_hz": [float(f) for f in modes.freq_hz],
        "suggested_points_in": [float(x) for x in np.round(m_to_in(layout.points_m), 3)],
        "driving_point_in": float(np.round(m_to_in(layout.driving_point_m), 3)),
    }


# --- the virtual rig -------------------------------------------------------------------------


def virtual_bat(
    profile, material, points_m: np.ndarray, *, sensor_offset_m: float = 0.0,
    sensor_mass_kg: float = 0.0, bungee_k_n_per_m: float = 0.0, beam: Beam = "timoshenko",
    alter: str | None = None, moisture_pct: float = 0.0, zeta1: float = 0.005,
    rel_noise: float = 0.0,
):
    """Place a bat on the virtual rig.

    A bat on the virtual rig (``updating.simulate.virtual_bat.VirtualBat``: impact points
    ``points_m``, accelerometer at the driving point, bungees, damping, noise), ``alter``ed
    if given.
    """
    from updating.simulate.virtual_bat import VirtualBat

    return VirtualBat(
        profile, material, points_m, sensor_offset_m=sensor_offset_m,
        sensor_mass_kg=sensor_mass_kg, bungee_k_n_per_m=bungee_k_n_per_m, beam=beam,
        core=core_spec(alter), moisture_pct=moisture_pct, zeta1=zeta1, rel_noise=rel_noise)


def simulate_bat_test(bat, freq_hz: np.ndarray, seed: int | None):
    """Simulate a roving-hammer test (``FrfTest``) of a bat at ``freq_hz``, seed ``seed``."""
    from updating.simulate.virtual_bat import simulate_test

    return simulate_test(bat, freq_hz, seed=seed)


def write_frf(path, test) -> None:
    """Write an ``FrfTest`` (UFF, CSV or NPZ by extension; atomic)."""
    from ema.io.frf_io import write_test

    write_test(path, test)


def nuisance_names() -> tuple[str, ...]:
    """Every nuisance of the nuisance-rich fleet (``updating.simulate.nuisances``)."""
    from updating.simulate.nuisances import NUISANCES

    return tuple(NUISANCES)


def bat_words(kind: FieldKind) -> str:
    """Name a simulated bat by its alteration: "an unaltered bat", "a nails bat"."""
    if kind in (None, "none"):
        return "an unaltered bat"
    name = str(kind)
    return f"{'an' if name[0] in 'aeiou' else 'a'} {name} bat"


def simulate_field_case(
    seed: int | None, kind: FieldKind, nuisances: tuple[str, ...], integrity: Integrity | None,
    folder, progress: Progress = _quiet, calipers: int = 0, records: int | None = None,
) -> tuple[dict, str]:
    """Draw one random bat of the nuisance-rich fleet and write its files.

    One random bat of the nuisance-rich fleet written as a lab hands it over (profile.csv,
    meta.json, baseline.uff, retest.uff, retest.json, truth.json in ``folder``;
    ``updating.simulate.field_fleet``; with ``calipers`` N > 0 also retest_profile.csv read
    at N orientations; with ``records`` N, both tests' dates, rooms and N moisture readings
    a station, meta.json holding the registration's conditions,
    ``updating.simulate.meter``). Returns (paths by name, the expected verdict);
    ``progress`` is told before the files are simulated.
    """
    from updating.simulate.field_fleet import draw_case, write_case
    from updating.simulate.meter import with_lab_records

    rng = np.random.default_rng(seed)
    case = draw_case(rng, kind, nuisances, integrity)
    noise_seed = int(rng.integers(2**31))
    if records is not None:
        case = with_lab_records(case, noise_seed, records)
    progress(f"simulating {bat_words(kind)} with {', '.join(nuisances) or 'no nuisance'} ...")
    paths = write_case(case, folder, seed=noise_seed, truth=True, retest_profile=calipers,
                       registration=records is not None)
    return paths, case.expected


def bat_modal_model(profile_path, meta_path, points_m: np.ndarray, accel_point: int,
                    alter: str | None, note: Progress = _quiet):
    """Build a bat's modal model for the virtual rig.

    (ModalModel, accelerometer point index) of a bat at ``points_m`` from its profile
    (updating's virtual bat: FE model, Timoshenko, 3 g accelerometer at the driving point --
    point ``accel_point``, 1-based, 0: the point nearest 1 in from the barrel end -- two
    150 N/m bungees), for `rig serve --profile`.
    """
    from updating.simulate.virtual_bat import VirtualBat, modal_model

    profile = bat_profile(profile_path)
    material = wood(meta_path, None, note)
    accel = (accel_point - 1) if accel_point else -1
    bat = VirtualBat(profile, material, points_m, sensor_index=accel, sensor_mass_kg=0.003,
                     bungee_k_n_per_m=150.0, core=core_spec(alter))
    modal, _ = modal_model(bat)
    return modal, bat.sensor_point()


def uniform_beam_model(length_m: float, mass_kg: float, f1_hz: float, points_m: np.ndarray):
    """ModalModel of a free-free uniform beam in closed form (``rigs.modal_model``)."""
    from rigs.modal_model import uniform_beam_modes

    return uniform_beam_modes(length_m, mass_kg, f1_hz, points_m)


# --- the demo's bat --------------------------------------------------------------------------


DEMO_TRUTH = {"E_scale": 1.04, "density_scale": 0.97, "e_over_g": 13.0, "sensor_mass_g": 3.0,
              "bungee_k_n_per_m": 150.0, "noise_pct": 0.5, "df_hz": 1.0, "fmax_hz": 3200.0,
              "averages": 5}
"""The built-in bat as the real board behaves (4 % stiffer and 3 % lighter than the
handbook, E/G 13, 3 g accelerometer, bungees, 0.5 % noise; 5 hits a point, the files
carrying their coherence, as the rig records them: docs/noise.md)."""
DEMO_RETEST = {"alteration": "cork:depth=10,d=1.0,ratio=0.3,plug=1", "moisture_pct": 0.8,
               "sensor_offset_in": 0.05}
"""The demo's re-test weeks later: moisture, a re-mounted accelerometer, a cork."""


def builtin_dir() -> Path:
    """Return the built-in bat's files (package data ``batlab/builtin``)."""
    return Path(__file__).resolve().parent.parent / "builtin"


@dataclass(frozen=True)
class DemoFiles:
    """The demo's files: the built-in bat's profile.csv and meta.json, its baseline and re-test."""

    profile: Path
    meta: Path
    baseline: Path
    retest: Path


def simulate_demo_pair(work: Path, seed: int, progress: Progress = _quiet,
                       alteration: str | None = DEMO_RETEST["alteration"]) -> DemoFiles:
    """Write the demo's pair of tests.

    Copy the built-in bat to ``work`` and write its baseline and re-test as UFF (the re-test
    after moisture and a re-mounted sensor, and ``alteration`` unless None; noise seeds
    ``seed`` and ``seed + 1``).
    """
    from updating.model.lab_input import read_meta
    from updating.model.material import Material
    from updating.model.profile import read_profile_csv
    from updating.simulate.virtual_bat import VirtualBat, simulate_test, with_changes

    truth, retest = DEMO_TRUTH, DEMO_RETEST
    profile_path, meta_path = work / "profile.csv", work / "meta.json"
    for src, dst in ((builtin_dir() / "profile.csv", profile_path),
                     (builtin_dir() / "meta.json", meta_path)):
        shutil.copyfile(src, dst)
    profile, meta = read_profile_csv(profile_path), read_meta(meta_path)
    w = meta.material.scaled(truth["E_scale"], truth["density_scale"])
    bat = VirtualBat(profile, Material(w.E_pa, w.rho_kg_m3, truth["e_over_g"], w.nu),
                     np.sort(meta.points_m), sensor_mass_kg=truth["sensor_mass_g"] / 1000,
                     bungee_k_n_per_m=truth["bungee_k_n_per_m"],
                     rel_noise=truth["noise_pct"] / 100, n_averages=truth["averages"])
    freq = np.arange(0.0, truth["fmax_hz"] + truth["df_hz"] / 2, truth["df_hz"])
    retest_bat = with_changes(bat, core=core_spec(alteration),
                              moisture_pct=retest["moisture_pct"],
                              sensor_offset_m=retest["sensor_offset_in"] * IN_TO_M)
    baseline_path, retest_path = work / "baseline.uff", work / "retest.uff"
    progress(f"simulating the baseline test of {meta.serial} on the virtual rig")
    write_frf(baseline_path, simulate_test(bat, freq, seed=seed))
    progress("simulating the re-test weeks later: moisture +0.8 points, accelerometer "
             "re-mounted" + ("" if alteration is None else f", altered ({alteration})"))
    write_frf(retest_path, simulate_test(retest_bat, freq, seed=seed + 1))
    return DemoFiles(profile_path, meta_path, baseline_path, retest_path)
