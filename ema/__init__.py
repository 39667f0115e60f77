"""Experimental modal analysis: FRF files, modal parameter estimation, scaling, MAC.

Second stage of the data flow rigs -> ema -> updating -> batlab.
"""
