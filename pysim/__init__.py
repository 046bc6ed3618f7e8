"""piezo-mpi: modified Prandtl-Ishlinskii hysteresis models of piezo actuators,
their inverse compensators as FMI 2.0 co-simulation FMUs, and the co-simulation,
identification and diagnosis tools around them.

Layers (each imports only the ones below it; ``tests/test_layers.py`` checks):

==================  =====================================================  ==========================
layer               what                                                   may import
==================  =====================================================  ==========================
``pysim.cli``       the ``pysim`` command                                  everything below
``pysim.studies``   a compensator identified on a simulated rig and        core, specs, fmu, cosim,
                    co-simulated against it                                identification
``pysim.testing``   shared by tests and benchmarks: synthetic records,     core, specs, fmu, cosim,
                    FMU builds                                             identification
``pysim.diagnosis`` residual analysis, cause catalog, extended models      core, identification
``pysim.specs``     shipped specs (``models/``): data the layers below     core, cosim
                    load by name (models, stage, rig)
``pysim.cosim``     co-simulation harness, rig, stages, bandwidth,         core, fmu
                    tracking
``pysim.identification``  measured-data loader, constrained least squares  core
``pysim.fmu``       FMI 2.0 FMU builder (``build-fmu``)                    core
``pysim.core``      operators, models, output stages, invertibility,       (numpy only; C kernel)
                    inverse, C kernel binding, spec files, error measures
==================  =====================================================  ==========================
"""

__version__ = "0.1.0"
