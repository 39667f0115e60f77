import sys

from batlab.cli import main

sys.exit(main())
