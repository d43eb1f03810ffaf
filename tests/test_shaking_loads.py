"""Which load a process force is: a `force` load comes from outside the machine, so the frame
that holds the machine feels it in the shaking force; a `joint_force` in the guide is reacted by
the frame itself (a press's punch against its own bed), so the mounts do not. Both move the
mechanism alike: the same driver torque, and shaking forces that differ by the load itself."""

from __future__ import annotations

import numpy as np

import linkdyn
from linkdyn import design

FORCE = 'kind = "force"\nbody = "slider"\npoint = "F"\nvalue = [-200.0, 0.0]'
INSIDE = 'kind = "joint_force"\njoint = "J4"\nvalue = -200.0'


def test_a_force_load_is_in_the_shaking_force_and_a_joint_force_is_not(tmp_path):
    text = linkdyn.example_path("slider_crank").read_text()
    assert FORCE in text
    (tmp_path / "outside.toml").write_text(text)
    (tmp_path / "inside.toml").write_text(text.replace(FORCE, INSIDE))
    t = np.linspace(0.0, 0.2, 25)
    out, ins = (linkdyn.analyze(linkdyn.load(tmp_path / f"{n}.toml"), t, backend="numpy")
                for n in ("outside", "inside"))
    np.testing.assert_allclose(out.dyn.tau, ins.dyn.tau, rtol=1e-12, atol=1e-12)
    # the difference is the load on the slider and its moment about the origin, by hand: the
    # guide is 20 mm above the crank axis (the origin), F = (-200, 0) N: M = -y Fx = 4 N m
    diff = design.shaking_wrench(out) - design.shaking_wrench(ins)
    np.testing.assert_allclose(diff, np.broadcast_to([4.0, -200.0, 0.0], diff.shape),
                               rtol=0, atol=1e-9)
