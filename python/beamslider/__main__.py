"""``python -m beamslider`` = the ``beamslider`` command."""

import sys

from .cli import main

sys.exit(main())
