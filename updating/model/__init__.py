"""The bat's finite-element reference.

Profile, wood, sections, elements, assembly, modes, mass properties, calibrated reference.
"""
