"""Core subcommands of the ``mocap-mj`` command line (one module each)."""
