"""Lab files in JSON read into a dict, with one wording for every unusable file.

Every lab JSON file (meta.json, retest.json, a bar description, an acquisition sidecar or
channel description) is read by ``read_json_object``; its errors are one line naming the
file: "PATH: no such file", "PATH: not a text file", "PATH: not valid JSON (MSG, line N)",
"PATH: expected a JSON object".
"""

from __future__ import annotations

import json
from pathlib import Path


def read_json_object(path: str | Path) -> dict:
    """Read a JSON file whose top level is an object.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict
        The file's object.

    Raises
    ------
    ValueError
        One line naming the file when it is missing, unreadable, not JSON or not an object.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    try:
        raw = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc.msg}, line {exc.lineno})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    except OSError as exc:
        raise ValueError(f"{path}: cannot read ({exc.strerror})") from None
    if not isinstance(raw, dict):
        raise ValueError(f"{path}: expected a JSON object")
    return raw
