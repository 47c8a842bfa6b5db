"""``python -m mocap_mj`` is ``mocap-mj``."""

import sys

from .cli import main

sys.exit(main())
