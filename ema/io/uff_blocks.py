"""Universal File Format plumbing shared by the FRF (58) and mode (55) files.

A UFF file is a sequence of datasets, each between two ``    -1`` marker lines; the line
after the opening marker holds the dataset number (I6), and ``58b`` marks a binary 58 whose
data follow its 11 ASCII header records as raw bytes (UC-SDRL binary 58; see
``pyuff.datasets.dataset_58.get_structure_58``). The file is split here once, sequentially:
a binary block is skipped by its byte count, computed from record 7 (the ``n_bytes`` field
of the 58b line is not trusted: pyuff 2.5 writes half the true count for complex data).

Dataset 164 gives unit factors f (file units per SI unit: SI value = file value / f), dataset
15 (or 2411) the nodes; both are decoded by pyuff's own extractors.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pyuff.datasets.dataset_15 import _extract15
from pyuff.datasets.dataset_164 import _extract164
from pyuff.datasets.dataset_2411 import _extract2411

_NONBLANK = re.compile(rb"\S")
_END_LINE = re.compile(rb"\n[ \t]*-1[ \t]*\r?(?:\n|\Z)")
_END_AFTER_BINARY = re.compile(rb"[\r\n]*[ \t]*-1[ \t]*(\r?\n|$)")
UNIT_SYSTEMS = {1: "SI", 2: "BG", 3: "MG", 4: "BA", 5: "MM", 6: "CM", 7: "IN", 8: "GM", 9: "US"}


@dataclass(frozen=True)
class UffBlock:
    """One dataset of a UFF file.

    Attributes
    ----------
    index : int
        1-based position of the dataset in the file.
    type : int
        dataset number (15, 58, 164, ...).
    binary : bool
        True for a binary 58 (``58b``).
    text : bytes
        the dataset from its opening marker line up to (not including) its end marker,
        as pyuff's extractors expect it.
    header : tuple[bytes, ...]
        for 58, its 11 header records after the type line (ID lines 1-5, records
        6-11); empty for other datasets.
    data : bytes
        for 58, the data part (ASCII text or raw bytes); empty for other datasets.
    type_line : bytes
        the dataset number record (carries the binary format of a 58b).
    """

    index: int
    type: int
    binary: bool
    text: bytes
    header: tuple[bytes, ...]
    data: bytes
    type_line: bytes

    def where(self, path: Path) -> str:
        """Location prefix for error messages."""
        return f"{path}: dataset #{self.index} (type {self.type}{'b' if self.binary else ''})"


def fields(line: bytes, widths: list[int]) -> list[str]:
    """Split an 80-column record into its fixed-width fields, stripped."""
    s = line.decode("latin-1").rstrip("\r\n").ljust(sum(widths))
    out, i = [], 0
    for w in widths:
        out.append(s[i : i + w].strip())
        i += w
    return out


def data_count_58(header: tuple[bytes, ...], where: str) -> tuple[int, int, bool, int]:
    """Return (ord_data_type, num_pts, even, number of stored values) from record 7 of a 58."""
    rec = fields(header[6], [10, 10, 10])
    try:
        ord_type, num_pts, even = int(rec[0]), int(rec[1]), int(rec[2])
    except ValueError:
        raise ValueError(f"{where}: unreadable record 7 (data form) {rec}") from None
    if ord_type not in (2, 4, 5, 6):
        raise ValueError(f"{where}: ordinate data type {ord_type} is not 2, 4, 5 or 6")
    if num_pts < 1 or even not in (0, 1):
        raise ValueError(f"{where}: bad record 7 (num_pts={num_pts}, abscissa spacing={even})")
    per_pt = (2 if ord_type in (5, 6) else 1) + (0 if even else 1)
    return ord_type, num_pts, bool(even), num_pts * per_pt


def _line_at(raw: bytes, pos: int) -> tuple[bytes, int]:
    """Return the line starting at ``pos`` (without its newline) and the offset after it."""
    end = raw.find(b"\n", pos)
    end = len(raw) if end < 0 else end
    return raw[pos:end].rstrip(b"\r"), min(end + 1, len(raw))


def split_uff(raw: bytes, path: Path) -> list[UffBlock]:
    """Split a whole UFF file into datasets, in one sequential pass.

    Parameters
    ----------
    raw : bytes
        The file's content.
    path : Path
        The file, for messages.

    Returns
    -------
    list of UffBlock
        The datasets in file order.

    Raises
    ------
    ValueError
        Not UFF, or damaged (truncated, a missing marker, a binary count that disagrees with
        the file), naming the file and the dataset.
    """
    blocks: list[UffBlock] = []
    pos = 0
    while True:
        m = _NONBLANK.search(raw, pos)
        if m is None:
            break
        start = raw.rfind(b"\n", 0, m.start()) + 1
        marker, after = _line_at(raw, start)
        index = len(blocks) + 1
        if marker.strip() != b"-1":
            line_no = raw.count(b"\n", 0, start) + 1
            shown = marker[:40].decode("latin-1", "replace")
            if not blocks:
                raise ValueError(
                    f"{path}: not a UFF file (line {line_no} is {shown!r}, "
                    "expected the dataset start marker '    -1')"
                )
            raise ValueError(
                f"{path}: line {line_no} after dataset #{index - 1} is {shown!r}, "
                "expected a dataset start marker '    -1'"
            )
        type_line, body = _line_at(raw, after)
        try:
            dtype = int(type_line[:6])
        except ValueError:
            raise ValueError(
                f"{path}: dataset #{index}: unreadable dataset number record {type_line[:20]!r}"
            ) from None
        binary = type_line[6:7] in (b"b", b"B")
        where = f"{path}: dataset #{index} (type {dtype}{'b' if binary else ''})"
        header: tuple[bytes, ...] = ()
        data = b""
        if dtype == 58:
            lines, data_start = [], body
            for _ in range(11):
                if data_start >= len(raw):
                    raise ValueError(f"{where}: truncated (file ends in the header records)")
                line, data_start = _line_at(raw, data_start)
                lines.append(line)
            header = tuple(lines)
        if dtype == 58 and binary:
            ord_type, _, _, count = data_count_58(header, where)
            n_bytes = count * (8 if ord_type in (4, 6) else 4)
            stop = data_start + n_bytes
            if stop > len(raw):
                raise ValueError(
                    f"{where}: truncated (binary data needs {n_bytes} bytes, "
                    f"the file holds {len(raw) - data_start})"
                )
            data = raw[data_start:stop]
            m_end = _END_AFTER_BINARY.match(raw, stop)
            if m_end is None:
                if not raw[stop:].strip():
                    raise ValueError(f"{where}: truncated (no end marker '    -1')")
                raise ValueError(
                    f"{where}: binary data are not followed by the end marker '    -1' "
                    "(record 7 byte count disagrees with the file)"
                )
            end, pos = m_end.start(), m_end.end()
        else:
            m_end = _END_LINE.search(raw, body - 1)
            if m_end is None:
                raise ValueError(f"{where}: truncated (no end marker '    -1')")
            end, pos = m_end.start() + 1, m_end.end()
            if dtype == 58:
                if data_start > end:
                    raise ValueError(f"{where}: fewer than 11 header records before its end")
                data = raw[data_start:end]
        blocks.append(UffBlock(index, dtype, binary, raw[start:end], header, data, type_line))
    if not blocks:
        raise ValueError(f"{path}: not a UFF file (empty)")
    return blocks


def _pyuff(extract, block: UffBlock, path: Path) -> dict:
    try:
        return extract(block.text.decode("latin-1"))
    except Exception as exc:  # pyuff raises bare Exception
        raise ValueError(f"{block.where(path)}: unreadable ({exc})") from None


def read_units(block: UffBlock, path: Path) -> tuple[float, float, str]:
    """Return (length factor, force factor, unit system name) of a dataset 164."""
    d = _pyuff(_extract164, block, path)
    lf, ff = d["length"], d["force"]
    if not (np.isfinite(lf) and np.isfinite(ff) and lf > 0 and ff > 0):
        raise ValueError(f"{block.where(path)}: unit factors must be positive (length={lf}, "
                         f"force={ff})")
    return lf, ff, UNIT_SYSTEMS.get(d["units_code"], str(d["units_code"]))


def read_nodes(block: UffBlock, path: Path, length_factor: float) -> dict[int, float]:
    """Return node number -> x position in metres, from a dataset 15 or 2411."""
    d = _pyuff(_extract15 if block.type == 15 else _extract2411, block, path)
    nums = np.asarray(d["node_nums"], dtype=float)
    x = np.asarray(d["x"], dtype=float)
    if nums.size != x.size or not np.all(np.isfinite(x)) or not np.all(np.abs(nums) < 2**31) \
            or np.any(nums != np.round(nums)):
        raise ValueError(f"{block.where(path)}: malformed node records")
    return {int(n): float(v) / length_factor for n, v in zip(nums, x, strict=True)}


def si_units_dset() -> dict:
    """Build the pyuff dict of a dataset 164 declaring SI (factors 1; kelvin offset 273.15)."""
    return {"type": 164, "units_code": 1, "units_description": "SI", "temp_mode": 2,
            "length": 1.0, "force": 1.0, "temp": 1.0, "temp_offset": 273.15}


def nodes_dset(node_x_m: dict[int, float]) -> dict:
    """Build the pyuff dict of a dataset 15: the nodes on the bat axis, x in m, y = z = 0."""
    nums = np.array(sorted(node_x_m), dtype=int)
    x = np.array([node_x_m[n] for n in nums], dtype=float)
    if not np.all(np.isfinite(x)):
        raise ValueError("node positions must be finite")
    zero = np.zeros_like(x)
    return {"type": 15, "node_nums": nums, "x": x, "y": zero, "z": zero}
