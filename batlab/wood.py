"""One default wood for every command that builds or simulates a bat (`model`, `simulate`,
`rig serve --profile`): meta.json's species values when given, else the stated default, the
paper's white birch (E 1.8e6 psi, 0.02167 lbf/in^3), with the same E/G everywhere.

The choice is never silent: without --meta the command says on stderr which wood it uses.
"""

from __future__ import annotations

import sys

DEFAULT_E_OVER_G = 14.0
"""E/G of a typical bat wood (ash, maple, birch: 9-16 along the grain). Only Timoshenko
models use it; the Euler-Bernoulli model ignores shear."""


def describe(material, e_over_g: float) -> str:
    from updating.model.units import LBF_IN3_TO_KG_M3, PSI_TO_PA

    return (f"E {material.E_pa / PSI_TO_PA:,.0f} psi, {material.rho_kg_m3 / LBF_IN3_TO_KG_M3:.5f}"
            f" lbf/in^3, E/G {e_over_g:g}")


def wood(meta_path: str | None, e_over_g: float | None, command: str):
    """The Material for ``command``: meta.json's (``read_meta``) or the paper's birch, with
    ``e_over_g`` (default DEFAULT_E_OVER_G); says on stderr which default it took."""
    from updating.model.lab_input import read_meta
    from updating.model.material import Material, paper_material

    g = DEFAULT_E_OVER_G if e_over_g is None else float(e_over_g)
    if g <= 0:
        raise ValueError(f"--e-over-g {e_over_g}: must be positive")
    if meta_path:
        return read_meta(meta_path, g).material
    base = paper_material()
    material = Material(base.E_pa, base.rho_kg_m3, g, base.nu)
    print(f"batlab {command}: no --meta: the default wood, the paper's white birch "
          f"({describe(material, g)})", file=sys.stderr)
    return material
