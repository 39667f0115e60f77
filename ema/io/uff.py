"""FRF files in the Universal File Format: ``read_uff`` and ``write_uff``.

Layout (docs/files.md): dataset 164 (units), dataset 15 (nodes; x in m along the bat axis
from the knob end, y = z = 0), then one dataset 58 per FRF (function type 4, complex, even
abscissa in Hz; response and reference direction +Z = 3) and, when known, one dataset 58 per
coherence (function type 6, real). batlab writes SI and double precision, binary (58b) by
default; it reads ASCII or binary, any unit system declared by a 164 (SI = file / factor),
and accelerance, mobility or receptance by the ordinate numerator type (12, 11, 8) over a
force denominator (13 or 9).

batlab's key=value tokens in the 58 ID lines (read from any ID line):
    estimator=H1             FRF estimator (H1, H2, Hv); bare words H1/H2 are recognised too
    exp_window_tau_s=0.0625  time constant (s) of an exponential window on the response
    f0_hz=0.0 df_hz=0.5      the frequency axis to full precision (record 7 keeps 6 digits)
    averages=5               hits averaged into the FRF and its coherence (also n_averages=,
                             navg=); the coherence's variance needs it (ema.shapes.noise)

The 58 data block is parsed by one whitespace split of the block (ASCII) or one
``np.frombuffer`` (binary); anything that defeats the fast path (fields run together,
Fortran D exponents) goes to pyuff's own 58 extractor.
"""

from __future__ import annotations

import gc
import io
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyuff
from pyuff.datasets.dataset_58 import _extract58

from ema.io.atomic_write import atomic_write
from ema.io.frf_assembly import assemble, even_axis, require_finite, same_axis
from ema.io.frf_data import FrfTest
from ema.io.uff_blocks import (
    UffBlock,
    data_count_58,
    fields,
    nodes_dset,
    read_nodes,
    read_units,
    si_units_dset,
    split_uff,
)

NUMERATOR_TYPES = {12: "accelerance", 11: "mobility", 8: "receptance"}
"""Record 9 specific data type of the ordinate numerator -> FrfTest.quantity."""
FORCE_TYPES = (13, 9)
_TOKEN = re.compile(r"([A-Za-z_]\w*)=(\S+)")
_ESTIMATOR_WORD = re.compile(r"\b(H1|H2|Hv)\b")
_UNITS_LABEL = {"accelerance": "m/s^2", "mobility": "m/s", "receptance": "m"}


@dataclass(frozen=True)
class Function58:
    """One decoded dataset 58, SI units, before assembly into an FrfTest."""

    where: str
    func_type: int
    rsp_node: int
    ref_node: int
    axis: tuple[int, float, float]  # (lines, f0 Hz, df Hz)
    values: np.ndarray
    quantity: str | None
    estimator: str | None
    tau_s: float | None
    averages: int | None = None


def _int_fields(line: bytes, widths: list[int], names: list[str], where: str) -> dict[str, int]:
    vals = fields(line, widths)
    try:
        return {n: int(v or 0) for n, v in zip(names, vals, strict=True) if n}
    except ValueError:
        raise ValueError(f"{where}: unreadable record {vals}") from None


def _tokens(ids: list[str]) -> tuple[dict[str, str], str | None]:
    toks = dict(kv for s in ids for kv in _TOKEN.findall(s))
    est = toks.get("estimator")
    if est is None:
        words = [w for s in ids for w in _ESTIMATOR_WORD.findall(s)]
        est = words[0] if words else None
    return toks, est


def _float_token(toks: dict[str, str], key: str, where: str) -> float | None:
    if key not in toks:
        return None
    try:
        v = float(toks[key])
    except ValueError:
        raise ValueError(f"{where}: token {key}={toks[key]!r} is not a number") from None
    if not (np.isfinite(v) and v > 0) and key != "f0_hz":
        raise ValueError(f"{where}: token {key}={toks[key]!r} must be positive")
    return v


def _ascii_numbers(data: bytes, count: int) -> np.ndarray | None:
    """Parse the ``count`` numbers of an ASCII 58 data block; None when the fast paths fail.

    pandas' C tokenizer reads the block as a table (one row per record, the last one
    padded with NaN); a table that is not ``count`` numbers in full rows falls back to a
    plain split of the block (which also covers NaN written into the data).
    """
    import pandas as pd  # here, not at the top: binary files (batlab's own) never need it

    try:
        a = pd.read_csv(io.BytesIO(data), sep=r"\s+", header=None, dtype=float).to_numpy()
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        a = None
    if a is not None and a.shape[0] == -(-count // a.shape[1]) and not np.isnan(a[:-1]).any():
        flat = a.ravel()
        if np.isnan(flat[count:]).all() and not np.isnan(flat[count - a.shape[1] : count]).any():
            return flat[:count]
    tokens = data.split()
    if len(tokens) != count:
        return None
    try:
        return np.array(tokens, dtype=float)
    except ValueError:
        return None


def _points(
    block: UffBlock, ord_type: int, num_pts: int, even: bool, count: int, path: Path
) -> tuple[np.ndarray | None, np.ndarray]:
    """(abscissa or None when even, ordinates) of a 58 data block: fast path, else pyuff."""
    where = block.where(path)
    is_complex = ord_type in (5, 6)
    vals = None
    if block.binary:
        bo = fields(block.type_line, [6, 1, 6, 6])
        if bo[3] not in ("", "2"):
            raise ValueError(f"{where}: floating-point format {bo[3]} is not IEEE 754 (2)")
        dt = ("<" if bo[2] in ("", "1") else ">") + ("f8" if ord_type in (4, 6) else "f4")
        vals = np.frombuffer(block.data, dtype=dt, count=count).astype(float)
    else:
        vals = _ascii_numbers(block.data, count)
    if vals is not None:
        v = vals.reshape(num_pts, count // num_pts)
        y = v[:, -2] + 1j * v[:, -1] if is_complex else v[:, -1].copy()
        return (None if even else v[:, 0].copy()), y
    try:
        d = _extract58(block.text)
    except Exception:
        raise ValueError(f"{where}: unreadable data block (expected {count} numbers)") from None
    y = np.asarray(d["data"])
    if y.size != num_pts:
        raise ValueError(
            f"{where}: data block holds {y.size} points, record 7 says {num_pts} "
            "(truncated or corrupt)"
        )
    return (None if even else np.asarray(d["x"], dtype=float)), y


def _decode_58(
    block: UffBlock, path: Path, length_factor: float, force_factor: float
) -> Function58 | None:
    """Decode one dataset 58 to SI; None when it is neither an FRF (4) nor a coherence (6)."""
    where = block.where(path)
    h = block.header
    ids = [s.decode("latin-1").strip() for s in h[:5]]
    r6 = _int_fields(
        h[5], [5, 10, 5, 10, 11, 10, 4, 11, 10, 4],
        ["func_type", "", "", "", "", "rsp_node", "rsp_dir", "", "ref_node", "ref_dir"], where,
    )
    if r6["func_type"] not in (4, 6):
        return None
    where = f"{where}, response node {r6['rsp_node']} / reference node {r6['ref_node']}"
    ord_type, num_pts, even, count = data_count_58(h, where)
    rec7 = fields(h[6], [10, 10, 10, 13, 13])
    try:
        x0, dx = float(rec7[3] or 0), float(rec7[4] or 0)
    except ValueError:
        raise ValueError(f"{where}: unreadable abscissa in record 7 {rec7}") from None
    spec = [_int_fields(h[k], [10], ["t"], where)["t"] for k in (7, 8, 9)]
    abscissa, numerator, denominator = spec
    if abscissa not in (0, 1, 18):
        raise ValueError(f"{where}: abscissa data type {abscissa} is not frequency (18)")
    toks, estimator = _tokens(ids)

    x, y = _points(block, ord_type, num_pts, even, count, path)
    is_complex = ord_type in (5, 6)
    require_finite(y, where)

    if even:
        if not dx > 0:
            raise ValueError(f"{where}: abscissa increment {dx} is not positive")
        f0_t, df_t = _float_token(toks, "f0_hz", where), _float_token(toks, "df_hz", where)
        if df_t is not None and abs(df_t - dx) <= 1e-5 * dx:
            dx = df_t
            if f0_t is not None and abs(f0_t - x0) <= 1e-5 * max(abs(x0), dx):
                x0 = f0_t
        axis = (num_pts, x0, dx)
    else:
        axis = (num_pts, *even_axis(x, where))

    dirs = (r6["rsp_dir"], r6["ref_dir"])
    if abs(dirs[0]) not in (0, 2, 3) or abs(dirs[1]) not in (0, 2, 3) or (
        dirs[0] and dirs[1] and abs(dirs[0]) != abs(dirs[1])
    ):
        raise ValueError(
            f"{where}: directions {dirs} are not one transverse axis (+-3 Z, or +-2 Y)"
        )
    quantity = None
    if r6["func_type"] == 4:
        if not is_complex:
            raise ValueError(f"{where}: FRF stored as real data (ordinate type {ord_type})")
        if numerator not in (0, *NUMERATOR_TYPES) or denominator not in (0, *FORCE_TYPES):
            raise ValueError(
                f"{where}: ordinate {numerator}/{denominator} is not acceleration (12), "
                "velocity (11) or displacement (8) over force (13)"
            )
        quantity = NUMERATOR_TYPES.get(numerator, "accelerance")
        sign = np.sign(dirs[0] or 1) * np.sign(dirs[1] or 1)
        y = y * (sign * force_factor / length_factor)
    else:
        if is_complex:
            raise ValueError(f"{where}: coherence stored as complex data")
        if np.any(y < -1e-6) or np.any(y > 1 + 1e-6):
            raise ValueError(f"{where}: coherence outside 0..1")
    return Function58(
        where, r6["func_type"], r6["rsp_node"], r6["ref_node"], axis, y, quantity,
        estimator, _float_token(toks, "exp_window_tau_s", where), _averages(toks, where),
    )


AVERAGES_TOKENS = ("averages", "n_averages", "navg")
"""ID-line tokens naming the hits averaged into an FRF (``averages=5``): the coherence's
variance needs them (``ema.shapes.noise``)."""


def _averages(toks: dict[str, str], where: str) -> int | None:
    """Return the hits averaged, from the first of ``AVERAGES_TOKENS`` present."""
    for key in AVERAGES_TOKENS:
        v = _float_token(toks, key, where)
        if v is not None:
            if v != int(v):
                raise ValueError(f"{where}: token {key}={toks[key]!r} is not a whole number")
            return int(v)
    return None


def read_uff(path: str | os.PathLike) -> FrfTest:
    """Read an FRF test from a UFF file (164 + 15 + 58s, ASCII or binary) into SI units.

    Parameters
    ----------
    path : str or os.PathLike
        The UFF file.

    Returns
    -------
    FrfTest
        FRFs (and coherences, if stored) in SI units of their quantity, node positions in m.

    Raises
    ------
    OSError
        The file cannot be read.
    ValueError
        Its content is not a usable FRF test (naming the file, the dataset and the problem).
    """
    path = Path(path)
    blocks = split_uff(path.read_bytes(), path)
    lf, ff, system = 1.0, 1.0, "SI"
    nodes: dict[int, float] = {}
    funcs: list[Function58] = []
    binary: set[bool] = set()
    for b in blocks:
        if b.type == 164:
            lf, ff, system = read_units(b, path)
        elif b.type in (15, 2411):
            nodes.update(read_nodes(b, path, lf))
        elif b.type == 58:
            fn = _decode_58(b, path, lf, ff)
            if fn is not None:
                funcs.append(fn)
                binary.add(b.binary)
    frfs = [fn for fn in funcs if fn.func_type == 4]
    if not frfs:
        raise ValueError(f"{path}: no FRF (dataset 58 with function type 4)")
    first = frfs[0]
    for fn in funcs:
        if not same_axis(fn.axis, first.axis):
            raise ValueError(
                f"{fn.where}: frequency axis {_axis_str(fn.axis)} differs from "
                f"{_axis_str(first.axis)} of the first FRF"
            )
        for node in (fn.rsp_node, fn.ref_node):
            if node not in nodes:
                raise ValueError(f"{fn.where}: node {node} is not defined in any dataset 15")
    for attr, what in (("quantity", "FRF quantity"), ("tau_s", "exp_window_tau_s")):
        vals = {getattr(fn, attr) for fn in frfs}
        if len(vals) > 1:
            raise ValueError(f"{path}: the FRFs disagree on {what}: {sorted(map(str, vals))}")
    where = str(path)
    resp, ref, frf = assemble([(f.rsp_node, f.ref_node) for f in frfs], [f.values for f in frfs],
                              where)
    coherence = _coherence([fn for fn in funcs if fn.func_type == 6], resp, ref, len(first.values))
    estimators = {fn.estimator for fn in frfs} - {None}
    n, f0, df = first.axis
    meta = {"source": str(path), "format": "uff", "uff_binary": binary == {True},
            "units": system}
    if estimators:
        meta["estimator"] = estimators.pop() if len(estimators) == 1 else "mixed"
    averages = {fn.averages for fn in frfs} - {None}
    if averages:
        meta["n_averages"] = min(averages)  # differing counts: the fewest, the noisiest
    return FrfTest(
        freq_hz=f0 + np.arange(n) * df, frf=frf, response_nodes=resp, reference_nodes=ref,
        node_x_m=nodes, quantity=first.quantity, coherence=coherence,
        exp_window_tau_s=first.tau_s, meta=meta,
    )


def _axis_str(axis: tuple[int, float, float]) -> str:
    n, f0, df = axis
    return f"({n} lines from {f0:.6g} Hz by {df:.6g} Hz)"


def _coherence(
    cohs: list[Function58], resp: np.ndarray, ref: np.ndarray, n_lines: int
) -> np.ndarray | None:
    """(F, n_resp, n_ref) coherence, NaN where a pair has none; None when there is none."""
    if not cohs:
        return None
    out = np.full((n_lines, resp.size, ref.size), np.nan)
    for c in cohs:
        i, j = np.flatnonzero(resp == c.rsp_node), np.flatnonzero(ref == c.ref_node)
        if not (i.size and j.size):
            raise ValueError(f"{c.where}: coherence for a node pair that has no FRF")
        out[:, i[0], j[0]] = c.values
    return out


def write_uff(path: str | os.PathLike, test: FrfTest, binary: bool = True) -> None:
    """Write ``test`` as a UFF file (SI, double precision) through pyuff, atomically.

    Coherence pairs that are all NaN are skipped.

    Parameters
    ----------
    path : str or os.PathLike
        The file, replaced atomically.
    test : FrfTest
        The test, SI units.
    binary : bool, optional
        Write binary 58b datasets (default) rather than ASCII 58.

    Raises
    ------
    ValueError
        For data UFF cannot carry faithfully (NaN/inf FRFs, uneven axis, nodes without
        positions).
    """
    path = Path(path)
    where = f"{path} (writing)"
    f0, df = even_axis(test.freq_hz, where)
    require_finite(test.frf, where)
    missing = [int(n) for n in (*test.response_nodes, *test.reference_nodes)
               if int(n) not in test.node_x_m]
    if missing:
        raise ValueError(f"{where}: nodes {missing} have no position in node_x_m")
    coh = test.coherence
    if coh is not None and coh.shape != test.frf.shape:
        raise ValueError(f"{where}: coherence shape {coh.shape} differs from FRF shape")
    ids = _id_lines(test, f0, df)
    dsets = [si_units_dset(), nodes_dset(test.node_x_m)]
    for func, label in ((4, "FRF"), (6, "coherence")):
        arr = test.frf if func == 4 else coh
        if arr is None:
            continue
        for i, r in enumerate(test.response_nodes):
            for j, q in enumerate(test.reference_nodes):
                col = arr[:, i, j]
                if func == 6 and np.all(np.isnan(col)):
                    continue
                require_finite(col, f"{where}: {label} {r}/{q}")
                dsets.append(_dset58(func, int(r), int(q), col, f0, df, test.quantity,
                                     ids, binary, len(dsets) - 1))
    atomic_write(path, lambda tmp: _write_checked(tmp, dsets, test, path))


def _write_checked(tmp: Path, dsets: list[dict], test: FrfTest, path: Path,
                   attempts: int = 2) -> None:
    """Write ``dsets`` to ``tmp`` through pyuff and read it back before it is moved into place.

    pyuff's binary 58 writer reopens the file itself and leaves its last text handle to the
    garbage collector; where a profiler holds the frame (a Dask worker's statistical profiler)
    that handle can flush after the next dataset and scramble the file. The file is read back
    and compared with ``test`` (exact for binary doubles, 1e-9 relative for ASCII); a file that
    does not read back is written again after a collection, then refused.
    """
    for _ in range(attempts):
        pyuff.UFF(str(tmp)).write_sets(dsets, mode="overwrite")
        gc.collect()  # close pyuff's orphaned handle now, not at some later flush
        try:
            back = read_uff(tmp)
        except ValueError:
            continue
        if back.frf.shape == test.frf.shape and np.allclose(back.frf, test.frf, rtol=1e-9,
                                                            atol=0.0):
            return
    raise OSError(f"{path}: the written UFF file does not read back as the test (pyuff)")


def _id_lines(test: FrfTest, f0: float, df: float) -> list[str]:
    est = test.meta.get("estimator")
    tau = test.exp_window_tau_s
    n_avg = test.meta.get("n_averages")
    line4 = " ".join(
        ([f"estimator={est}"] if est else [])
        + ([f"exp_window_tau_s={float(tau)!r}"] if tau is not None else [])
        + ([f"averages={int(n_avg)}"] if n_avg is not None else [])
    )
    return [
        "batlab " + test.quantity,
        str(test.meta.get("serial", "NONE"))[:80] or "NONE",
        str(test.meta.get("date", "NONE"))[:80] or "NONE",
        line4 or "NONE",
        f"f0_hz={float(f0)!r} df_hz={float(df)!r}",
    ]


def _dset58(
    func: int, rsp: int, ref: int, values: np.ndarray, f0: float, df: float, quantity: str,
    ids: list[str], binary: bool, func_id: int,
) -> dict:
    """Build the pyuff dict of one dataset 58: FRF (4, complex, per force) or coherence (6)."""
    frf = func == 4
    num = {v: k for k, v in NUMERATOR_TYPES.items()}[quantity] if frf else 0
    return {
        "type": 58, "binary": int(binary), "func_type": func, "func_id": func_id,
        "id1": ids[0] if frf else "batlab coherence", "id2": ids[1], "id3": ids[2],
        "id4": ids[3], "id5": ids[4],
        "rsp_node": rsp, "rsp_dir": 3, "ref_node": ref, "ref_dir": 3, "load_case_id": 0,
        "abscissa_spacing": 1, "abscissa_spec_data_type": 18, "abscissa_axis_lab": "Frequency",
        "abscissa_axis_units_lab": "Hz",
        "ordinate_spec_data_type": num, "ordinate_axis_units_lab": _UNITS_LABEL[quantity]
        if frf else "NONE",
        "orddenom_spec_data_type": 13 if frf else 0,
        "orddenom_axis_units_lab": "N" if frf else "NONE",
        "data": np.asarray(values, dtype=complex if frf else float),
        "x": f0 + np.arange(values.size) * df,
    }
