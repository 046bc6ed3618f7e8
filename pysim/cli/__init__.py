"""The ``pysim`` command line (:func:`pysim.cli.main.main`), on top of every layer."""
