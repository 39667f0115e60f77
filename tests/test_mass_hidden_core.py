"""Hidden effect: a random core is recognised from the change of mass properties alone."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.model.assembly import build_model
from updating.model.mass_properties import core_from_mass_change, mass_properties
from updating.model.material import Material
from updating.model.profile import make_profile
from updating.model.sections import Core
from updating.model.units import IN_TO_M

# a smooth pro-style profile: knob, handle, taper, barrel
X_IN = [0, 0.5, 1.0, 2, 8, 14, 20, 24, 28, 33.5, 34]
D_IN = [1.6, 1.6, 1.0, 0.95, 0.97, 1.2, 1.9, 2.4, 2.55, 2.55, 2.45]
PROFILE = make_profile(np.array(X_IN) * IN_TO_M, np.array(D_IN) * IN_TO_M)
WOOD = Material(12.0e9, 640.0, 14.0)


@settings(max_examples=15, deadline=None)
@given(depth_in=st.floats(6.0, 11.0), d_in=st.floats(0.75, 1.25),
       ratio=st.sampled_from([0.2, 0.33, 0.4, 1.5, 1.8, 2.2]), plug_in=st.floats(0.5, 1.5))
def test_core_recovered_from_mass_properties(depth_in, d_in, ratio, plug_in):
    core = Core(d_in * IN_TO_M, depth_in * IN_TO_M, ratio, 0.0, plug_in * IN_TO_M)
    before = mass_properties(build_model(PROFILE, WOOD, beam="timoshenko"))
    after = mass_properties(build_model(PROFILE, WOOD, beam="timoshenko", core=core))
    found = core_from_mass_change(before, after, PROFILE.length_m, core.plug_m, WOOD.rho_kg_m3)
    assert found.length_m == pytest.approx(core.depth_m - core.plug_m, rel=1e-6)
    assert found.diameter_m == pytest.approx(core.diameter_m, rel=1e-4)
    assert found.fill_density_ratio == pytest.approx(ratio, rel=1e-4)


def test_density_neutral_fill_is_reported_invisible():
    core = Core(1.0 * IN_TO_M, 10 * IN_TO_M, 1.0, 0.0, IN_TO_M)
    before = mass_properties(build_model(PROFILE, WOOD))
    after = mass_properties(build_model(PROFILE, WOOD, core=core))
    with pytest.raises(ValueError, match="density-neutral"):
        core_from_mass_change(before, after, PROFILE.length_m, IN_TO_M, WOOD.rho_kg_m3)
