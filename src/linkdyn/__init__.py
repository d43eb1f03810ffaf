"""linkdyn: recursive (DeNOC) kinematics and inverse dynamics of planar closed-loop mechanisms.

>>> import linkdyn, numpy as np
>>> mech = linkdyn.load(linkdyn.example_path("hoeken"))
>>> sol = linkdyn.analyze(mech, np.linspace(0.0, 4 / 3, 361))
>>> round(float(abs(sol.effort("J1")).max()), 3)
1.119
"""

from __future__ import annotations

from importlib import resources

from .analysis import Solution, analyze
from .forward import Simulation, simulate
from .modal import Equilibrium, Modes, equilibrium, modes
from .errors import AssemblyError, LinkdynError, ModelError
from .io import load_model, model_from_dict
from .io.writer import model_to_dict, save
from .model import Body, Driver, Joint, Load, Model
from .studies import sweep
from .studies.optimize import optimize
from ._version import __version__

load = load_model


def example_path(name: str):
    """Path of a bundled example model, e.g. ``example_path("hoeken")``; the models for
    ``simulate`` live in ``examples/simulate`` (e.g. ``example_path("hoeken_motor")``), the
    spatial ones in ``examples/spatial`` (e.g. ``example_path("rsur")``)."""
    path = resources.files("linkdyn").joinpath("examples", f"{name}.toml")
    if not path.is_file():
        for folder in ("simulate", "spatial"):
            other = resources.files("linkdyn").joinpath("examples", folder, f"{name}.toml")
            if other.is_file():
                return other
    return path


__all__ = ["load", "load_model", "model_from_dict", "analyze", "Solution", "simulate",
           "Simulation", "Model", "Body",
           "Joint", "Driver", "Load", "ModelError", "AssemblyError", "LinkdynError",
           "example_path", "save", "model_to_dict", "sweep", "optimize", "equilibrium",
           "modes", "Equilibrium", "Modes"]
