"""Run the command line as ``python -m batlab`` (the same as the ``batlab`` script)."""

import sys

from batlab.cli import main

sys.exit(main())
