"""Modal parameters in the Universal File Format: ``write_modes_uff`` and ``read_modes_uff``.

Layout: dataset 164 (SI), dataset 15 (nodes, x in m along the bat axis, y = z = 0), one
dataset 55 per mode with the shape in the +Z (r3) component. Real shapes are written as
normal modes (analysis type 2: frequency in Hz and viscous damping ratio in record 8);
complex shapes as complex modes (analysis type 3) with the eigenvalue
lambda = -zeta w + i w sqrt(1 - zeta^2), w = 2 pi f, read back as f = |lambda| / 2 pi,
zeta = -Re(lambda) / |lambda|. pyuff writes 55 records in E13.5 (6 significant digits).
Shapes are stored as given; their units are not converted by a 164 on reading.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyuff
from pyuff.datasets.dataset_55 import _extract55

from ema.io.atomic_write import atomic_write
from ema.io.uff_blocks import nodes_dset, read_nodes, read_units, si_units_dset, split_uff


@dataclass(frozen=True)
class ModeSet:
    """Modes at measured nodes.

    Attributes
    ----------
    freq_hz : np.ndarray
        (m,) natural frequencies, Hz.
    damping_ratio : np.ndarray
        (m,) viscous damping ratios.
    shapes : np.ndarray
        (n_nodes, m) real or complex mode shapes (transverse, +Z).
    nodes : np.ndarray
        (n_nodes,) node numbers.
    node_x_m : np.ndarray
        (n_nodes,) node positions along the bat axis from the knob end, m.
    """

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    nodes: np.ndarray
    node_x_m: np.ndarray


def write_modes_uff(
    path: str | os.PathLike,
    freq_hz: np.ndarray,
    damping_ratio: np.ndarray,
    shapes: np.ndarray,
    nodes: np.ndarray,
    node_x_m: np.ndarray,
) -> None:
    """Write modes as 164 + 15 + one 55 per mode (real shapes: type 2, complex: type 3).

    Parameters
    ----------
    path : str or os.PathLike
        The UFF file, replaced atomically.
    freq_hz : np.ndarray
        (m,) natural frequencies, Hz.
    damping_ratio : np.ndarray
        (m,) viscous damping ratios (or one for all modes).
    shapes : np.ndarray
        (n_nodes, m) real or complex mode shapes.
    nodes : np.ndarray
        (n_nodes,) node numbers.
    node_x_m : np.ndarray
        (n_nodes,) node positions along the bat axis, m.

    Raises
    ------
    ValueError
        Sizes that do not match, or NaN/inf in the modal parameters.
    """
    path = Path(path)
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    z = np.broadcast_to(np.asarray(damping_ratio, dtype=float), f.shape)
    phi = np.asarray(shapes).reshape(-1, f.size)
    nodes = np.asarray(nodes, dtype=int)
    x = np.asarray(node_x_m, dtype=float)
    if nodes.size != phi.shape[0] or x.size != nodes.size:
        raise ValueError(f"{path}: shapes {phi.shape}, nodes {nodes.size} and positions "
                         f"{x.size} do not match")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(z)) and np.all(np.isfinite(phi))):
        raise ValueError(f"{path}: NaN or inf in the modal parameters")
    cplx = np.iscomplexobj(phi)
    zero = np.zeros(nodes.size, dtype=phi.dtype)
    dsets = [si_units_dset(), nodes_dset(dict(zip(nodes.tolist(), x.tolist(), strict=True)))]
    for k in range(f.size):
        d = {"type": 55, "id1": "batlab modes", "id2": f"mode {k + 1}", "model_type": 1,
             "data_ch": 2, "spec_data_type": 8, "load_case": 1, "mode_n": k + 1,
             "node_nums": nodes, "r1": zero, "r2": zero, "r3": phi[:, k]}
        w = 2 * np.pi * f[k]
        if cplx:
            d.update(analysis_type=3, eig=complex(-z[k] * w, w * np.sqrt(1 - z[k] ** 2)))
        else:
            d.update(analysis_type=2, freq=f[k], modal_damp_vis=z[k])
        dsets.append(d)
    atomic_write(path, lambda tmp: pyuff.UFF(str(tmp)).write_sets(dsets, mode="overwrite"))


def read_modes_uff(path: str | os.PathLike) -> ModeSet:
    """Read the 55 modes (analysis type 2 or 3) of a UFF file, with node positions from 15.

    Parameters
    ----------
    path : str or os.PathLike
        The UFF file.

    Returns
    -------
    ModeSet
        Frequencies (Hz), damping ratios, shapes and the nodes with their positions (m).

    Raises
    ------
    ValueError
        No modes, unknown nodes, node sets that differ between modes, or NaN/inf (one line
        naming the file and, where there is one, the dataset).
    """
    path = Path(path)
    lf = 1.0
    positions: dict[int, float] = {}
    freqs, zetas, cols = [], [], []
    nodes = None
    for b in split_uff(path.read_bytes(), path):
        if b.type == 164:
            lf = read_units(b, path)[0]
        elif b.type in (15, 2411):
            positions.update(read_nodes(b, path, lf))
        elif b.type == 55:
            try:
                d = _extract55(b.text.decode("latin-1"))
            except Exception as exc:  # pyuff raises bare Exception
                raise ValueError(f"{b.where(path)}: unreadable ({exc})") from None
            if d["analysis_type"] == 2:
                freqs.append(d["freq"])
                zetas.append(d["modal_damp_vis"])
            elif d["analysis_type"] in (3, 7):
                lam = d["eig"]
                freqs.append(abs(lam) / (2 * np.pi))
                zetas.append(-lam.real / abs(lam) if lam else 0.0)
            else:
                continue
            order = np.asarray(d["node_nums"], dtype=int)
            if nodes is None:
                nodes = order
            elif not np.array_equal(np.sort(order), np.sort(nodes)):
                raise ValueError(f"{b.where(path)}: node set differs from the first mode's")
            col = dict(zip(order.tolist(), np.asarray(d["r3"]), strict=True))
            cols.append(np.array([col[n] for n in nodes.tolist()]))
    if nodes is None:
        raise ValueError(f"{path}: no modes (dataset 55, analysis type 2 or 3)")
    missing = [n for n in nodes.tolist() if n not in positions]
    if missing:
        raise ValueError(f"{path}: nodes {missing} are not defined in any dataset 15")
    shapes = np.stack(cols, axis=1)
    if not np.all(np.isfinite(shapes)):
        raise ValueError(f"{path}: NaN or inf in the mode shapes")
    return ModeSet(np.array(freqs), np.array(zetas), shapes, nodes,
                   np.array([positions[n] for n in nodes.tolist()]))
