"""What the tests and the benchmarks share: synthetic records with hidden
effects (:mod:`pysim.testing.synthetic`) and FMU builds of the default model
(:mod:`pysim.testing.fmus`).  Part of the package, so both use one copy.
"""
