"""The paper's corked-bat case end to end, and its Figures 2 and 3 (element change bars).

Test data are the corked model's modes sampled at the translational DOFs only (optionally
with noise); batlab runs SEREP + one MSSO pass (the paper's method) and then its refinement.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ema.io.atomic_write import atomic_write
from updating.correlate.measured import sampled_modes, with_noise
from updating.model.assembly import BatModel, build_model
from updating.model.material import paper_material
from updating.model.modes import model_modes
from updating.model.profile import paper_profile
from updating.model.sections import Core
from updating.model.units import IN_TO_M
from updating.msso.core_reading import CoreReading, read_core
from updating.msso.factors import ElementFactors
from updating.msso.update import ElementUpdate, update_elements

__all__ = [
    "PAPER", "PaperCase", "TRUE", "element_rows", "plot_figures", "run_paper_case",
]


PAPER = {"alpha_mean": -0.0918, "beta_mean": -0.0167, "core_diameter_in": 0.971,
         "density_ratio": 0.291}
TRUE = {"alpha_mean": -(2 / 3) / 2.7**2, "beta_mean": -(1 / 2.7) ** 4, "core_diameter_in": 1.0,
        "density_ratio": 1 / 3}
CORED = slice(23, 32)  # elements 24-32 (1-based from the knob)


@dataclass(frozen=True)
class PaperCase:
    """The paper's corked-bat case: the reference model, the element update, two summaries."""

    reference: BatModel
    update: ElementUpdate
    final: dict
    one_pass: dict


def _summary(model: BatModel, f: ElementFactors, reading: CoreReading) -> dict:
    a, b = f.alpha_trans[CORED], f.beta_bend[CORED]
    # read the core over the true cored elements, as the paper does
    D = 2.7 * IN_TO_M
    d = D * max(-b.mean(), 0.0) ** 0.25
    r = 1 + a.mean() * (D / d) ** 2 if d > 0 else float("nan")
    return {"alpha_mean": float(a.mean()), "beta_mean": float(b.mean()),
            "core_diameter_in": float(d / IN_TO_M), "density_ratio": float(r),
            "region_found_in": ([float(reading.start_m / IN_TO_M), float(reading.end_m / IN_TO_M)]
                                if reading.found else None)}


def run_paper_case(n_modes: int = 6, noise_pct: float = 0.0, seed: int = 0) -> PaperCase:
    """Build the reference and corked paper bat; the test: corked modes at translational DOFs."""
    ref = build_model(paper_profile(), paper_material())
    cork = build_model(paper_profile(), paper_material(),
                       core=Core(IN_TO_M, 10 * IN_TO_M, 1 / 3, 0.0, IN_TO_M))
    t = model_modes(cork, n_modes + 2).elastic()
    a = cork.translational_dofs
    test = sampled_modes(t, a, cork.node_x_m)
    if noise_pct > 0:
        test = with_noise(test, noise_pct / 100, 5e-4, np.random.default_rng(seed))
        sig = {"shape_sigma": noise_pct / 100, "freq_sigma": 5e-4}
    else:
        sig = {"shape_sigma": 1e-6, "freq_sigma": 1e-7, "prior_sigma": None}
    u = update_elements(ref, test.freq_hz, test.shapes, a, **sig)
    from dataclasses import replace

    one = replace(u, factors=u.one_pass, std=None, draws=None)
    return PaperCase(ref, u, _summary(ref, u.factors, read_core(ref, u)),
                     _summary(ref, u.one_pass, read_core(ref, one)))


def element_rows(model: BatModel, f: ElementFactors) -> list[dict]:
    """Tabulate the element factors (element ends in inches, alpha, beta)."""
    x = model.node_x_m / IN_TO_M
    return [{"x0_in": float(x[i]), "x1_in": float(x[i + 1]), "alpha": float(f.alpha_trans[i]),
             "beta": float(f.beta_bend[i])} for i in range(model.n_elements)]


def plot_figures(case: PaperCase, out_dir: str | Path) -> list[Path]:
    """Draw Figures 2 and 3 of the paper.

    Figure 2 (stiffness change) and Figure 3 (mass change) per element, one pass and
    final, against the truth; written as PNG (temporary name, then rename).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model = case.reference
    xc = 0.5 * (model.node_x_m[:-1] + model.node_x_m[1:]) / IN_TO_M
    width = np.diff(model.node_x_m) / IN_TO_M * 0.4
    paths = []
    for fig_no, attr, label, truth in ((2, "beta_bend", "stiffness change beta",
                                        TRUE["beta_mean"]),
                                       (3, "alpha_trans", "mass change alpha",
                                        TRUE["alpha_mean"])):
        fig, ax = plt.subplots(figsize=(8, 3.5))
        ax.bar(xc - width / 2, getattr(case.update.one_pass, attr), width, label="one MSSO pass")
        ax.bar(xc + width / 2, getattr(case.update.factors, attr), width, label="batlab refined")
        tv = np.zeros(model.n_elements)
        tv[CORED] = truth
        ax.step(model.node_x_m[:-1] / IN_TO_M, tv, where="post", color="k", lw=1, label="true")
        ax.set_xlabel("element position from the knob, in")
        ax.set_ylabel(label)
        ax.set_title(f"Figure {fig_no}: element {label.split()[0]} changes, corked bat")
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = out / f"figure{fig_no}_{label.split()[0]}.png"
        atomic_write(path, lambda tmp, fig=fig: fig.savefig(tmp, dpi=120, format="png"))
        plt.close(fig)
        paths.append(path)
    return paths
