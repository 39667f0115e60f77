"""Suggested test points (`batlab model --n-points`): the barrel covered where a core can be,
the accelerometer 1.5 in from the barrel end, not on the end face."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from batlab.cli import main
from batlab.pipeline import summarise_model
from updating.model.assembly import build_model
from updating.model.material import Material
from updating.model.placement import BARREL_ZONE_IN, effective_independence
from updating.model.profile import paper_profile
from updating.model.units import IN_TO_M
from updating.simulate.fleet import pro_profile

WOOD = Material(1.8e6 * 6894.757, 600.0, 14.0)


def layout_in(profile, n):
    model = build_model(profile, WOOD, beam="timoshenko")
    out = summarise_model(model, n_points=n)
    return np.array(out["suggested_points_in"]), out["driving_point_in"]


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(8, 20))
def test_barrel_covered_and_sensor_off_the_end_face(seed, n):
    profile = pro_profile(np.random.default_rng(seed))
    L = profile.length_m / IN_TO_M
    pts, drive = layout_in(profile, n)
    assert pts.size == n and np.all(np.diff(pts) > 0.4)
    assert 1.0 <= L - drive <= 2.0 and drive == pts[-1]  # sensor 1-2 in from the end
    assert pts[0] >= 1.0 and pts[-1] <= L - 1.0  # no end face tapped
    zone = pts[pts >= L - BARREL_ZONE_IN - 0.01]  # points are rounded to 0.01 in
    gaps = np.diff(zone)
    assert zone[0] - (L - BARREL_ZONE_IN) <= 1.5  # a core's start can fall anywhere there
    assert gaps.max() <= (2.0 if n >= 11 else 3.0) + 1e-6
    assert np.sum(pts > 16.0) >= 5  # the old EfI layout had none between 16 and 34 in


def test_paper_bat_layout_and_cli(capsys):
    pts, drive = layout_in(paper_profile(), 16)
    assert drive == pytest.approx(paper_profile().length_m / IN_TO_M - 1.5)
    assert np.max(np.diff(pts[pts > 20.0])) <= 1.5 + 1e-6
    assert main(["model", "--json", "--n-points", "12"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["suggested_points_in"]) == 12 and out["driving_point_in"] == pytest.approx(drive)
    assert main(["model", "--n-points", "6"]) == 2
    # one error line (a notice of the default wood may precede it)
    err = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert len(err) == 1 and "--n-points 6" in err[0] and "barrel" in err[0]


def test_efi_keeps_fixed_rows_and_picks_independent_ones():
    """EfI on two modes of a string: the fixed rows stay; of the free rows it keeps the ones
    spanning both shapes (an antinode of each), not the nodes."""
    x = np.linspace(0, 1, 21)
    phi = np.column_stack([np.sin(np.pi * x), np.sin(2 * np.pi * x)])
    keep = effective_independence(phi, 4, keep=[0, 20])
    assert {0, 20} <= set(keep) and keep.size == 4
    free = sorted(set(keep) - {0, 20})
    assert all(abs(phi[i]).max() > 0.5 for i in free)
    with pytest.raises(ValueError):
        effective_independence(phi, 1)
