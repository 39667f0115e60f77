"""What a command converts and reads at the edge without loading a stage.

The lab's unit constants (``updating.model.units``: inches, pounds, psi, lbf/in^3 to SI) and
the reader of a JSON object file (``updating.model.json_input``) and the running code's
version (``batlab.version.code_version``, for the fleet's rows), re-exported here.
"""

from __future__ import annotations

from batlab.version import code_version
from updating.model.json_input import read_json_object
from updating.model.units import IN_TO_M, KG_M2_TO_LB_IN2, LB_TO_KG, LBF_IN3_TO_KG_M3, PSI_TO_PA

__all__ = [
    "IN_TO_M", "KG_M2_TO_LB_IN2", "LBF_IN3_TO_KG_M3", "LB_TO_KG", "PSI_TO_PA",
    "code_version", "read_json_object",
]
