"""The batlab application: command line, registry of bats, reports."""

__version__ = "0.1.0"
