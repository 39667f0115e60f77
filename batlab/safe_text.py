r"""Text read from a lab's files or a registry, made harmless for where it is shown.

A serial, a species or a note is whatever the lab's meta.json held, and a registry's rows are
whatever its file holds: shown as is, text can attack the reader. Three places, one rule each:

- a terminal (``for_terminal``): every control character (Unicode category Cc: C0, DEL, C1)
  and every format character (Cf: right-to-left marks and overrides, zero-width joiners, the
  byte-order mark) is written as a Python escape (``\x1b``, ``\u202e``), so no escape
  sequence, NUL or direction override reaches the terminal (newline and tab of a multi-line
  message excepted);
- a CSV cell (``for_csv_cell``): text beginning with ``=``, ``+``, ``-``, ``@``, a tab or a
  carriage return gets a leading ``'`` (OWASP, "CSV Injection"), so a spreadsheet shows it
  as text instead of running it as a formula;
- an HTML page (``for_page``): NUL (which HTML5 forbids in text) and the other C0 controls
  but tab, newline and carriage return become U+FFFD; HTML escaping is the page's own.
"""

from __future__ import annotations

import unicodedata

FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
"""What makes a spreadsheet read a CSV cell as a formula (OWASP)."""


def _escaped(ch: str) -> str:
    code = ord(ch)
    return f"\\x{code:02x}" if code < 0x100 else (f"\\u{code:04x}" if code < 0x10000
                                                   else f"\\U{code:08x}")


def for_terminal(text: object, keep: str = "") -> str:
    r"""Return ``str(text)`` with its control and format characters escaped.

    Parameters
    ----------
    text : object
        The value to print.
    keep : str
        Characters left as they are (``"\n\t"`` for a message of several lines).

    Returns
    -------
    str
        Printable text: ``\x1b[31m`` stays visible as those six characters.
    """
    s = str(text)
    if s.isprintable():  # the usual case: nothing to escape
        return s
    return "".join(ch if ch in keep or unicodedata.category(ch) not in ("Cc", "Cf")
                   else _escaped(ch) for ch in s)


def for_csv_cell(value: object) -> object:
    """Return a CSV cell's value with a formula neutralised (text only; numbers unchanged)."""
    if isinstance(value, str) and value.startswith(FORMULA_STARTS):
        return "'" + value
    return value


def for_page(text: str) -> str:
    """Return a page's text with NUL and the other C0 controls (but tab, LF, CR) as U+FFFD."""
    return "".join("\ufffd" if ord(ch) < 0x20 and ch not in "\t\n\r" else ch for ch in text)
