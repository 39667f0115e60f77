"""Run the command line as ``python -m batlab`` (the same as the ``batlab`` script)."""

import sys

from batlab.cli import main

if __name__ == "__main__":  # not when a spawned worker process (Dask, multiprocessing) imports it
    sys.exit(main())
