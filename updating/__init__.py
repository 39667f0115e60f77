"""The bat's finite-element model, SEREP, MSSO, localisation, calibration and diagnosis.

Third stage of the data flow rigs -> ema -> updating -> batlab.
"""
