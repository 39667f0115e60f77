"""batlab.fleet.cache (benchmarks/inspect_cache.py): a cached bat re-scored by the inspection
alone gives the verdict the files-to-verdict path (``field_row``) gives on the same seed, and
the registration record added at scoring time is the one write_case would have written."""


import pytest

from batlab.fleet import cache as inspect_cache


def test_cached_bat_scores_as_the_full_path():
    seed, kind = 7301, "cork"
    bat = inspect_cache.build_one(seed, kind, None)
    row = inspect_cache.score_one(bat)
    full = inspect_cache.field_row(seed, kind, None, True)
    assert row["status"] == full["status"] == "altered"
    assert row["F"] == pytest.approx(full["F"], rel=1e-6)
    assert row["start_err_in"] == pytest.approx(full["start_err_in"], abs=1e-9)
    reg = inspect_cache.registered_conditions(bat)
    assert reg.weight_kg == bat["registered"].weight_kg
    assert reg.temperature_c is not None and 0.002 <= reg.sensor_mass_kg <= 0.006
