"""The measured data sets shipped with piezo-mpi (installed as
``pysim.identification.datasets``); each folder holds the standard CSV, its
LICENSE and SOURCE.md.  ``convert.py`` made the CSVs from the originals."""
