"""FRF and mode files (UFF, CSV, NPZ), the in-memory test, atomic writes."""
