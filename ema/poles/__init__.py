"""Pole estimation: peak picking, LSCF/PolyMAX, stabilisation, sub-bands, refinement."""
