"""impactsim: explicit Lagrangian simulation of high-velocity impact between solid bodies."""

__version__ = "0.1.0"
