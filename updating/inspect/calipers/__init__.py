"""The re-test's caliper profile against the registration's: removal measured, not inferred.

The public face (../../../docs/kinds.md, "The re-test's caliper profile"); the work is in
its modules, each with one job:

- ``null``: the survey's stations paired with the registered profile, and what an unaltered
  bat's readings do (caliper noise, ovality, the registration's noise, placement, shrinkage);
- ``scan``: runs of stations read short, found by a scan with a stated false-alarm level;
- ``reading``: a run read as shaving, a flat or grooves, where and how much;
- ``compare``: the comparison (``compare_profiles``), the survey asked about one stretch named
  beforehand (its ``region_m``, ``RegionCheck``), and what it cannot see (``blind_spots``).

What the calipers read is joined with the vibration test's verdict beside this package, in
``updating.inspect.caliper_verdict`` (``with_calipers``), as the bending pairs' splits are in
``plane_split_verdict``: the verdict's type holds a ``CaliperResult``, so the join cannot
live below it.

Examples
--------
>>> from updating.inspect.calipers import compare_profiles  # doctest: +SKIP

See Also
--------
updating.model.calipers : a caliper survey (the file's readings) and what a caliper reads
    across a flat.
updating.simulate.calipers : the re-test survey of a virtual bat.
"""

from updating.inspect.calipers.compare import (
    CaliperResult,
    RegionCheck,
    blind_spots,
    compare_profiles,
    hidden_flat_depth_m,
)

__all__ = ["CaliperResult", "RegionCheck", "blind_spots", "compare_profiles",
           "hidden_flat_depth_m"]
