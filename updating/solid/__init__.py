"""A 3D solid finite-element check of the 1D bat model (scikit-fem, quadratic hexahedra)."""
