"""The ``actorswarm`` command line (see :mod:`actorswarm.cli.app`)."""
