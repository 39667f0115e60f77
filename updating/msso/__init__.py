"""The paper's method (MSSO).

Skyline equations, element factors, regularisation, iteration, core reading.
"""
