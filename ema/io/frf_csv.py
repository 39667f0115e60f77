"""FRF tests as one long-format CSV file, for people without UFF tools.

Layout (docs/files.md): optional ``# key=value`` comment lines first (``quantity``,
default accelerance; ``exp_window_tau_s``; anything else goes to meta, e.g. ``estimator``),
then a header and one row per frequency line per FRF:

    freq_hz,response_node,response_x_m,reference_node,reference_x_m,real,imag[,coherence]

SI units: Hz, m, and (m/s^2)/N for accelerance ((m/s)/N mobility, m/N receptance). Rows of
one FRF share one evenly spaced frequency axis; node positions ride along on every row.
Numbers are written with 17 significant digits, so a round trip is exact.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ema.io.atomic_write import atomic_write
from ema.io.frf_assembly import assemble, even_axis, require_finite, same_axis
from ema.io.frf_data import FrfTest

COLUMNS = ["freq_hz", "response_node", "response_x_m", "reference_node", "reference_x_m",
           "real", "imag"]


def write_frf_csv(path: str | os.PathLike, test: FrfTest) -> None:
    """Write ``test`` in the long CSV layout, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        The .csv file, replaced atomically.
    test : FrfTest
        The test, SI units (17 significant digits: the round trip is exact).
    """
    path = Path(path)
    f, nr, nf = test.frf.shape
    ii, jj = np.meshgrid(np.arange(nr), np.arange(nf), indexing="ij")
    ii, jj = np.repeat(ii.ravel(), f), np.repeat(jj.ravel(), f)
    resp, ref = test.response_nodes[ii], test.reference_nodes[jj]
    h = test.frf.transpose(1, 2, 0).ravel()
    table = {
        "freq_hz": np.tile(test.freq_hz, nr * nf),
        "response_node": resp, "response_x_m": test.x_m(resp),
        "reference_node": ref, "reference_x_m": test.x_m(ref),
        "real": h.real, "imag": h.imag,
    }
    if test.coherence is not None:
        table["coherence"] = test.coherence.transpose(1, 2, 0).ravel()
    head = {"quantity": test.quantity}
    if test.exp_window_tau_s is not None:
        head["exp_window_tau_s"] = repr(float(test.exp_window_tau_s))
    head.update({k: v for k, v in test.meta.items()
                 if k not in ("source", "format") and isinstance(v, str | int | float)})
    comments = "".join(f"# {k}={v}\n" for k, v in head.items())

    def write(tmp: Path) -> None:
        import pandas as pd  # here, not at the top: a UFF or NPZ test never loads pandas

        with open(tmp, "w", newline="") as fh:
            fh.write(comments)
            pd.DataFrame(table).to_csv(fh, index=False, float_format="%.17g")

    atomic_write(path, write)


def read_frf_csv(path: str | os.PathLike) -> FrfTest:
    """Read an FRF test in the long CSV layout.

    Parameters
    ----------
    path : str or os.PathLike
        The .csv file.

    Returns
    -------
    FrfTest
        The test, SI units.

    Raises
    ------
    ValueError
        The file is not an FRF CSV file (one line naming it and the problem).
    """
    import pandas as pd  # here, not at the top: a UFF or NPZ test never loads pandas

    path = Path(path)
    head: dict[str, str] = {}
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            if not line.startswith("#"):
                break
            key, sep, val = line[1:].strip().partition("=")
            if sep:
                head[key.strip()] = val.strip()
    try:
        df = pd.read_csv(path, comment="#", skip_blank_lines=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not an FRF CSV file ({str(exc).splitlines()[0]})") from None
    missing = [c for c in COLUMNS if c not in df.columns]
    if missing:
        raise ValueError(f"{path}: not an FRF CSV file (missing columns {missing})")
    cols = COLUMNS + (["coherence"] if "coherence" in df.columns else [])
    try:
        df = df[cols].astype(float)
    except ValueError:
        raise ValueError(f"{path}: non-numeric values in the FRF columns") from None
    if df.empty:
        raise ValueError(f"{path}: no FRF rows")
    require_finite(df[COLUMNS].to_numpy(), f"{path}: row")
    nodes: dict[int, float] = {}
    for nc, xc in (("response_node", "response_x_m"), ("reference_node", "reference_x_m")):
        for n, x in df.groupby(nc, sort=False)[xc]:
            x0 = nodes.setdefault(int(n), float(x.iloc[0]))
            if x.max() - x.min() > 1e-9 or abs(x0 - x.iloc[0]) > 1e-9:
                raise ValueError(f"{path}: node {int(n)} has more than one position")
    pairs, frfs, cohs, first = [], [], [], None
    for (r, q), g in df.groupby(["response_node", "reference_node"], sort=False):
        where = f"{path}: FRF response node {int(r)} / reference node {int(q)}"
        axis = (len(g), *even_axis(g["freq_hz"].to_numpy(), where))
        if first is None:
            first = axis
        elif not same_axis(axis, first):
            raise ValueError(f"{where}: frequency axis differs from the first FRF's")
        pairs.append((int(r), int(q)))
        frfs.append(g["real"].to_numpy() + 1j * g["imag"].to_numpy())
        if "coherence" in g:
            cohs.append(g["coherence"].to_numpy())
    resp, ref, frf = assemble(pairs, frfs, str(path))
    coherence = assemble(pairs, cohs, str(path), "coherence")[2] if cohs else None
    n, f0, df_hz = first
    quantity = head.pop("quantity", "accelerance")
    tau = head.pop("exp_window_tau_s", None)
    try:
        tau_s = None if tau is None else float(tau)
        return FrfTest(
            freq_hz=f0 + np.arange(n) * df_hz, frf=frf, response_nodes=resp,
            reference_nodes=ref, node_x_m=nodes, quantity=quantity, coherence=coherence,
            exp_window_tau_s=tau_s, meta={**head, "source": str(path), "format": "csv"},
        )
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
