"""Test against model: measured modes, mode pairing (MAC), SEREP expansion."""
