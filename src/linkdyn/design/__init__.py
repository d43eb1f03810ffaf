"""Design quantities a mechanism designer judges a linkage by.

Everything here is computed from a solved run (:func:`linkdyn.analyze`) through the public
arrays of the :class:`~linkdyn.Solution`; all values are SI (m, rad, s, N, N m, J, W, kg m^2).

- :mod:`.fourbar`: four-bar loops, their Grashof type, transmission angle and mechanical
  advantage;
- :mod:`.shaking`: the shaking force and moment the moving links put on the ground;
- :mod:`.free_body`: each moving body's forces (its free-body diagram), which sum to m a_G;
- :mod:`.energy`: driver and load power and work, damper dissipation, the energy account of a
  run, energy fluctuation and the flywheel it calls for;
- :mod:`.speed`: the steady speed of the independent coordinates (mean, min, max, coefficient
  of fluctuation over the last turn) and the run-up to it;
- :mod:`.path`: joint travel and the straightness of a point's path;
- :mod:`.overview`: the run's summary (``summary.json``) and its numerical health.
"""

from . import checks
from .energy import (driver_energy, driver_power, energy_account, energy_fluctuation,
                     flywheel_inertia, load_energy)
from .fourbar import (FourBar, four_bars, mechanical_advantage, stops, transmission_angle,
                      velocity_ratio)
from .free_body import Force, free_body, mass_centre
from .overview import health, summary
from .path import TWO_PI, default_path_point, joint_travel, path_straightness
from .shaking import inertia_wrench, shaking_force, shaking_moment, shaking_wrench
from .speed import speed_statistics

__all__ = ["FourBar", "four_bars", "transmission_angle", "velocity_ratio",
           "mechanical_advantage", "stops", "shaking_wrench", "shaking_force", "shaking_moment",
           "inertia_wrench", "driver_power", "driver_energy", "energy_fluctuation",
           "flywheel_inertia", "joint_travel", "default_path_point", "path_straightness",
           "summary", "health", "TWO_PI", "load_energy", "energy_account", "speed_statistics",
           "Force", "free_body", "mass_centre"]
