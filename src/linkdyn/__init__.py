"""linkdyn: recursive (DeNOC) kinematics and inverse dynamics of planar closed-loop mechanisms."""

__version__ = "0.1.0"
