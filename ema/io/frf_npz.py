"""FRF tests as a numpy .npz archive (no pickles), the exact in-memory form of FrfTest.

Arrays: ``freq_hz`` (F,), ``frf`` (F, n_resp, n_ref) complex, ``response_nodes``,
``reference_nodes``, ``node_numbers`` and ``node_x_m`` (parallel), ``quantity`` (0-d str),
optional ``coherence`` (F, n_resp, n_ref) and ``exp_window_tau_s`` (0-d float), and
``meta_json`` (0-d str, JSON). SI units as in ema.io.frf_data.
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np

from ema.io.atomic_write import atomic_write
from ema.io.frf_assembly import even_axis, require_finite
from ema.io.frf_data import FrfTest

REQUIRED = ("freq_hz", "frf", "response_nodes", "reference_nodes", "node_numbers",
            "node_x_m", "quantity")


def write_frf_npz(path: str | os.PathLike, test: FrfTest) -> None:
    """Write ``test`` as an .npz archive, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        The .npz file, replaced atomically.
    test : FrfTest
        The test, SI units.
    """
    nums = np.array(sorted(test.node_x_m), dtype=int)
    arrays = {
        "freq_hz": test.freq_hz, "frf": test.frf,
        "response_nodes": test.response_nodes, "reference_nodes": test.reference_nodes,
        "node_numbers": nums, "node_x_m": np.array([test.node_x_m[n] for n in nums.tolist()]),
        "quantity": np.array(test.quantity),
        "meta_json": np.array(json.dumps(test.meta, default=str)),
    }
    if test.coherence is not None:
        arrays["coherence"] = test.coherence
    if test.exp_window_tau_s is not None:
        arrays["exp_window_tau_s"] = np.array(float(test.exp_window_tau_s))

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    atomic_write(path, write)


def read_frf_npz(path: str | os.PathLike) -> FrfTest:
    """Read an .npz FRF archive.

    Parameters
    ----------
    path : str or os.PathLike
        The .npz file.

    Returns
    -------
    FrfTest
        The test, SI units.

    Raises
    ------
    ValueError
        The archive is not an FRF test (one line naming the file and the problem).
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            a = {k: z[k] for k in z.files}
    except (zipfile.BadZipFile, ValueError, EOFError) as exc:
        raise ValueError(f"{path}: not a readable .npz archive ({exc})") from None
    missing = [k for k in REQUIRED if k not in a]
    if missing:
        raise ValueError(f"{path}: not an FRF archive (missing arrays {missing})")
    even_axis(a["freq_hz"], str(path))
    require_finite(np.asarray(a["frf"]), f"{path}: frf")
    try:
        meta = json.loads(str(a["meta_json"])) if "meta_json" in a else {}
        tau = float(a["exp_window_tau_s"]) if "exp_window_tau_s" in a else None
        return FrfTest(
            freq_hz=a["freq_hz"], frf=a["frf"], response_nodes=a["response_nodes"],
            reference_nodes=a["reference_nodes"],
            node_x_m=dict(zip(a["node_numbers"].astype(int).tolist(),
                              a["node_x_m"].astype(float).tolist(), strict=True)),
            quantity=str(a["quantity"]), coherence=a.get("coherence"), exp_window_tau_s=tau,
            meta={**meta, "source": str(path), "format": "npz"},
        )
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{path}: {exc}") from None
