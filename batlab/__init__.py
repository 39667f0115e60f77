"""The batlab application: command line, registry of bats, reports.

``batlab.__version__`` is the running code's version (``batlab.version.code_version``),
looked up on first use, not at import.
"""


def __getattr__(name: str):
    """Give ``__version__`` on first use (PEP 562)."""
    if name == "__version__":
        from batlab.version import code_version

        return code_version()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
