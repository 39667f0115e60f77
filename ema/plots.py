"""Plots of a modal fit (matplotlib, Agg).

Stabilisation diagram over the MIF, measured vs synthesised FRFs, AutoMAC. Each function writes
one PNG atomically and returns its path.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ema.io.atomic_write import atomic_write
from ema.modal_fit import ModalFit
from ema.shapes.mac import auto_mac


def _figure():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    atomic_write(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    _figure().close(fig)
    return path


def plot_stabilisation(fit: ModalFit, path: str | os.PathLike) -> Path:
    """Plot the poles over model order on the sum MIF, with the modes and the rejections.

    Stable in f, zeta and shape: filled; in f only: small crosses. Modes are red lines (dashed
    when kept on their own peak), rejected candidates dotted grey lines labelled with the reason.

    Parameters
    ----------
    fit : ModalFit
        The fit to draw.
    path : str or os.PathLike
        PNG written (atomically).

    Returns
    -------
    Path
        The path written.
    """
    plt = _figure()
    fig, ax = plt.subplots(figsize=(11, 5.5))
    if fit.sweep is not None and fit.stability is not None:
        sw, st = fit.sweep, fit.stability
        all_ = st.all
        f_only = st.freq & ~all_
        none = ~st.freq
        ax.plot(sw.freq_hz[none], sw.order[none], ".", color="0.8", ms=2, label="unstable")
        ax.plot(sw.freq_hz[f_only], sw.order[f_only], "x", color="tab:orange", ms=3,
                label="stable in f")
        ax.plot(sw.freq_hz[all_], sw.order[all_], "o", color="tab:green", ms=3,
                label="stable in f, zeta, shape")
        ax.set_ylabel("model order")
    for f, why in zip(fit.freq_hz, fit.decisions or [""] * fit.freq_hz.size, strict=True):
        ax.axvline(f, color="tab:red", lw=0.8, alpha=0.6, ls="--" if "own peak" in why else "-")
    lo, hi = fit.band_hz
    for r in fit.rejected:  # why each candidate was dropped, written along its line
        if lo <= r.freq_hz <= hi:
            ax.axvline(r.freq_hz, color="0.5", lw=0.6, ls=":")
            ax.text(r.freq_hz, 0.98, r.reason, transform=ax.get_xaxis_transform(), rotation=90,
                    va="top", ha="right", fontsize=6, color="0.35")
    ax.set_xlabel("frequency, Hz")
    ax.set_xlim(lo, hi)
    ax2 = ax.twinx()
    ax2.semilogy(fit.band_freq_hz, fit.mif, color="k", lw=0.8, label="sum MIF")
    ax2.set_ylabel("sum MIF, sum |H|^2")
    ax.set_title(f"Stabilisation diagram ({fit.method}); modes in red (dashed: kept on their own "
                 "peak), rejected candidates dotted with the reason")
    ax.legend(loc="upper left", fontsize=8)
    return _save(fig, Path(path))


def plot_synthesis(fit: ModalFit, measured: np.ndarray, path: str | os.PathLike,
                   n_frfs: int = 4) -> Path:
    """Plot measured vs synthesised FRF magnitudes: the driving point and the worst fits.

    Parameters
    ----------
    fit : ModalFit
        The fit to draw.
    measured : ndarray
        The test's FRFs on ``fit.band_freq_hz``, (F_band, n_resp, n_ref).
    path : str or os.PathLike
        PNG written (atomically).
    n_frfs : int
        FRFs drawn.

    Returns
    -------
    Path
        The path written.
    """
    plt = _figure()
    h = np.asarray(measured).reshape(fit.band_freq_hz.size, -1)
    s = fit.synth.reshape(h.shape)
    err = fit.synthesis_error.ravel()
    i_d, j_d = fit.driving_frf if fit.driving_frf is not None else (0, 0)  # none: the first
    dp = i_d * fit.synthesis_error.shape[1] + j_d
    picks = list(dict.fromkeys([dp] + [int(k) for k in np.argsort(err)[::-1][: n_frfs - 1]]))
    fig, axes = plt.subplots(len(picks), 1, figsize=(10, 2.6 * len(picks)), sharex=True,
                             squeeze=False)
    for ax, k in zip(axes[:, 0], picks, strict=True):
        ax.semilogy(fit.band_freq_hz, np.abs(h[:, k]), color="k", lw=0.8, label="measured")
        ax.semilogy(fit.band_freq_hz, np.abs(s[:, k]), color="tab:red", lw=0.8, ls="--",
                    label="synthesised")
        ax.set_ylabel(f"|H| FRF {k}")
        what = "driving point" if k == dp else f"FRF {k}"
        ax.set_title(f"{what}: relative misfit {err[k]:.2%}", fontsize=9)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("frequency, Hz")
    fig.tight_layout()
    return _save(fig, Path(path))


def plot_auto_mac(fit: ModalFit, path: str | os.PathLike) -> Path:
    """Plot the AutoMAC of the fitted (real) shapes.

    Parameters
    ----------
    fit : ModalFit
        The fit to draw.
    path : str or os.PathLike
        PNG written (atomically).

    Returns
    -------
    Path
        The path written.
    """
    plt = _figure()
    m = auto_mac(fit.real_shapes)
    fig, ax = plt.subplots(figsize=(5.5, 4.8))
    im = ax.imshow(m, vmin=0, vmax=1, cmap="viridis")
    labels = [f"{f:.0f}" for f in fit.freq_hz]
    ax.set_xticks(range(len(labels)), labels, rotation=90, fontsize=7)
    ax.set_yticks(range(len(labels)), labels, fontsize=7)
    for (i, j), v in np.ndenumerate(m):
        ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=6,
                color="w" if v < 0.5 else "k")
    fig.colorbar(im, ax=ax)
    ax.set_title("AutoMAC (mode frequency, Hz)")
    fig.tight_layout()
    return _save(fig, Path(path))


def plot_fit(fit: ModalFit, measured: np.ndarray, out_dir: str | os.PathLike) -> list[Path]:
    """Write all three plots into out_dir (created).

    Parameters
    ----------
    fit : ModalFit
        The fit to draw.
    measured : ndarray
        The test's FRFs on ``fit.band_freq_hz``, (F_band, n_resp, n_ref).
    out_dir : str or os.PathLike
        Directory for stabilisation.png, synthesis.png and automac.png.

    Returns
    -------
    list of Path
        The three paths.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return [
        plot_stabilisation(fit, out / "stabilisation.png"),
        plot_synthesis(fit, measured, out / "synthesis.png"),
        plot_auto_mac(fit, out / "automac.png"),
    ]
