"""Studies that combine the layers below: a compensator identified on a
simulated rig and co-simulated against it (:mod:`pysim.studies.rig_study`).
Built on :mod:`pysim.cosim` and :mod:`pysim.identification`."""
