"""One check for every number read from a lab's input files: finite and within its range.

Shared by the readers of UFF files (``ema.io``), meta.json, profiles and retest.json
(``updating``), so ``inf``, ``nan`` or ``1e300`` in any field is one line naming the field.
"""

from __future__ import annotations

import math


def finite_number(value, what: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    """Return ``value`` as a float after checking it is a finite number in ``[lo, hi]``.

    Parameters
    ----------
    value : object
        The number as read (a JSON number, or text holding one); booleans are refused.
    what : str
        The field, with its file, for the message (e.g. ``"meta.json: key 'weight_lb'"``).
    lo, hi : float
        Accepted range, in the field's own units.

    Returns
    -------
    float
        The value.

    Raises
    ------
    ValueError
        One line naming ``what``: not a number, not finite, or outside ``lo..hi``.
    """
    try:
        if isinstance(value, bool):
            raise TypeError
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{what} must be a number, not {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{what} must be a finite number, not {value!r}")
    if not lo <= number <= hi:
        if math.isinf(lo) or math.isinf(hi):
            raise ValueError(f"{what} = {number:g} is " + (f"above {hi:g}" if number > hi
                                                          else f"below {lo:g}"))
        raise ValueError(f"{what} = {number:g} is outside {lo:g}..{hi:g}")
    return number
