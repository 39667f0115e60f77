"""The physical test: serial protocol and driver, impact capture, the virtual rig.

First stage of the data flow rigs -> ema -> updating -> batlab; imports none of the others.
"""
