"""Shipped model specs (installed as ``pysim.specs``): ``default_mpi`` (the
paper's example, scaled) and ``flexure_stage`` (the default stage)."""
