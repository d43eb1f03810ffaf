"""What the MJCF exporters of planar (:mod:`linkdyn.io.mjcf`) and spatial
(:mod:`linkdyn.spatial.mjcf`) models share: the :class:`Mjcf` result, the servos' stiffness and
MuJoCo's lower bounds, the springs and dampers as tendons, the drivers as position actuators.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from ..model import Model

#: Stiffness of the drivers' servos: the mechanism's moving mass at its size (or, for a
#: slider, its moving mass) responds at about sqrt(KP_RATE) = 100 rad/s.
KP_RATE = 1e4  # 1/s^2
#: A massless link's or point mass's mass and inertia in MuJoCo (which needs them positive):
#: this fraction of the largest moving body's (``<compiler boundmass boundinertia>``).
BOUND = 1e-12


@dataclass(frozen=True)
class Mjcf:
    """An MJCF document and what it says about the mechanism.

    Attributes
    ----------
    text : str
        The MJCF XML.
    cut : tuple[str, ...]
        The joints closed by ``connect`` constraints (the cut joints of MuJoCo's tree).
    omitted : tuple[str, ...]
        What is left out or changed: the joints of ``leave_out`` (``"joint 'name'"``), zero
        masses and inertias (the bodies and MuJoCo's bounds) and the loads MJCF cannot hold
        (``"kind 'name'"``, the load's name or else its body).
    """

    text: str
    cut: tuple[str, ...]
    omitted: tuple[str, ...]


def num(x) -> str:
    """A number at round-trip precision."""
    return repr(float(x))


def light_bounds(compiler: ET.Element, moving, inertia: list[float], size: float) -> list[str]:
    """Give a massless link or a point mass MuJoCo's lower bounds (``<compiler boundmass
    boundinertia>``, :data:`BOUND` times the largest mass and inertia, at least 1e-14).

    Parameters
    ----------
    moving : list of Body
        The moving bodies (their ``mass``, kg, and ``name``).
    inertia : list of float
        Each body's smallest inertia, kg m^2 (planar: its one; spatial: the tensor's smallest
        principal value).
    size : float
        The mechanism's size, m.

    Returns
    -------
    list of str
        The note for :attr:`Mjcf.omitted` (empty when every body has mass and inertia).
    """
    if not any(b.mass <= 0 or i <= 0 for b, i in zip(moving, inertia)):
        return []
    # MuJoCo needs a positive mass and inertia on every moving body: a massless link or a
    # point mass gets its lower bound, BOUND times the largest
    big_m = max([b.mass for b in moving] + [0.0]) or 1.0
    big_i = max(list(inertia) + [big_m * size ** 2])
    # above MuJoCo's mjMINVAL (1e-15) whatever the units
    bound_m, bound_i = max(BOUND * big_m, 1e-14), max(BOUND * big_i, 1e-14)
    compiler.set("boundmass", num(bound_m))
    compiler.set("boundinertia", num(bound_i))
    light = [b.name for b, i in zip(moving, inertia) if b.mass <= 0 or i <= 0]
    return [f"a zero mass or inertia ({', '.join(light)}: MuJoCo's lower "
            f"bounds boundmass {bound_m:.3g} kg, boundinertia {bound_i:.3g} kg m^2)"]


def loads(root: ET.Element, model: Model) -> list[str]:
    """Write the springs and dampers as spatial tendons between their two points' sites
    (``stiffness``, ``springlength``, ``damping``); return the loads MJCF cannot hold (forces,
    torques, joint torques and forces: ``"kind 'name'"``, the load's name or else its body)."""
    omitted, tendons = [], []
    for ld in model.loads:
        if ld.kind in ("spring", "damper"):
            tendons.append(ld)
        else:
            omitted.append(f"{ld.kind} '{ld.name or ld.body}'")
    if tendons:
        tel = ET.SubElement(root, "tendon")
        for n, ld in enumerate(tendons):
            # a spring k (L - L0) or damper c dL/dt along the line between the two points
            attrs = ({"stiffness": num(ld.stiffness), "springlength": num(ld.free_length)}
                     if ld.kind == "spring" else {"damping": num(ld.damping)})
            sp = ET.SubElement(tel, "spatial", name=ld.name or f"{ld.kind}{n}", **attrs)
            ET.SubElement(sp, "site", site=f"{ld.body}.{ld.point}")
            ET.SubElement(sp, "site", site=f"{ld.body2}.{ld.point2}")
    return omitted


def drivers(root: ET.Element, model: Model, *, gear: dict, q: dict, angular: dict,
            moving_mass: float, size: float, kp: float | None) -> list[float]:
    """Write each driver as a ``<position>`` actuator on its joint (``gear`` by joint name,
    so that its length is ``q`` and its force the driver's effort) and its motion as a
    ``<custom><text>``; return the targets ``ctrl`` (``q`` at the export's time).

    ``angular`` says by joint name whether the coordinate is an angle; ``kp`` (N m/rad or
    N/m) defaults to ``KP_RATE`` times ``moving_mass`` (kg) times ``size`` squared (m^2; a
    sliding driver: times 1)."""
    ctrl = []
    if model.drivers:
        act = ET.SubElement(root, "actuator")
        custom = ET.SubElement(root, "custom")
        for d in model.drivers:
            turns = angular[d.joint]
            gain = kp if kp is not None else KP_RATE * moving_mass * (size ** 2 if turns else 1)
            # length = gear qpos = q; force on the dof = gear * effort
            ET.SubElement(act, "position", name=f"drive_{d.joint}", joint=d.joint,
                          gear=f"{gear[d.joint]} 0 0 0 0 0", kp=num(gain), dampratio="1")
            ET.SubElement(custom, "text", name=f"motion_{d.joint}",
                          data=(d.description or type(d.motion).__name__)
                          + f" (q_{d.joint} in {'rad' if turns else 'm'}; set ctrl to it)")
            ctrl.append(q[d.joint])
    return ctrl


def free(model: Model) -> bool:
    """Whether ``model`` has free degrees of freedom (``linkdyn simulate``'s models)."""
    from ..topology import mobility
    return mobility(model) > len(model.drivers)


def size_of(points: list[np.ndarray]) -> float:
    """Largest distance between two points (m), at least 1e-9."""
    P = np.array(points)
    return float(max(np.max(np.ptp(P, axis=0)), 1e-9)) if len(P) else 1.0
