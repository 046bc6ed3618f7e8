"""piezo-mpi: modified Prandtl-Ishlinskii hysteresis models of piezo actuators,
their inverse compensators as FMI 2.0 co-simulation FMUs, and the co-simulation,
identification and diagnosis tools around them."""

__version__ = "0.1.0"
