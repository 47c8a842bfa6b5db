"""``python -m mocap_mj`` is ``mocap-mj``."""

import sys

try:
    from .cli import main
except KeyboardInterrupt:  # Ctrl-C in the first milliseconds: as main answers it later
    print("mocap-mj: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
