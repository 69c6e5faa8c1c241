"""Sub-commands of the ``cdbrdf`` command line (one module each, see :mod:`cdbrdf.cli`)."""
