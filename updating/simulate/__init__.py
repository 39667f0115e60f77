"""Virtual bats and fleets: the truth behind simulated tests."""
