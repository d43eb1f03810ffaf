"""Spatial models through linkdyn.save and the design studies (sweep, optimize, compare)."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from test_writer import assert_same

import linkdyn
from linkdyn.cli import spatial_example_names
from linkdyn.io.writer import dumps_toml


def _same_columns(a: dict, b: dict, rtol: float = 1e-12):
    assert a.keys() == b.keys()
    for k in a:
        scale = max(float(np.max(np.abs(a[k]), initial=0.0)), 1e-12)
        np.testing.assert_allclose(b[k], a[k], rtol=0, atol=rtol * scale, err_msg=k)


@pytest.mark.parametrize("name", spatial_example_names())
def test_every_spatial_example_round_trips(name, tmp_path):
    m = linkdyn.load(linkdyn.example_path(name))
    m2 = linkdyn.load(linkdyn.save(m, tmp_path / f"{name}.toml"))
    assert_same(m, m2)
    assert m2.space == "spatial"


def test_a_posed_body_is_written_in_the_files_units(tmp_path):
    """A body frame turned and moved at the design pose (``origin``, ``rotation`` in degrees)
    and a full inertia tensor come back as the same body, and the same run."""
    data = tomllib.loads(linkdyn.example_path("rsur").read_text())
    crank = data["bodies"][1]
    # the crank's frame turned 90 deg about z and put at A: its points in that frame
    crank.update(origin=[0.0, 0.0, 0.0], rotation=[0.0, 0.0, 90.0],
                 points={"A": [0.0, 0.0, 0.0], "B": [0.0, -40.0, 0.0]}, com=[0.0, -20.0, 0.0],
                 inertia=[[40.0, 0.0, 0.0], [0.0, 3.75, 0.0], [0.0, 0.0, 40.0]])
    data["bodies"][2]["origin"] = [5.0, -2.0, 1.0]   # the coupler's frame moved
    data["bodies"][2]["points"] = {k: [x - o for x, o in zip(v, [5.0, -2.0, 1.0])]
                                   for k, v in data["bodies"][2]["points"].items()}
    data["bodies"][2]["com"] = [x - o for x, o in zip(data["bodies"][2]["com"], [5.0, -2.0, 1.0])]
    data["analysis"] = {"duration": 0.5, "samples": 9}
    src = tmp_path / "posed.toml"
    src.write_text(dumps_toml(data))
    m = linkdyn.load(src)
    written = tomllib.loads(linkdyn.save(m, tmp_path / "again.toml").read_text())
    body = written["bodies"][1]
    np.testing.assert_allclose(body["rotation"], [0, 0, 90], rtol=0, atol=1e-12)
    assert body["inertia"] == pytest.approx([40.0, 3.75, 40.0], rel=1e-14)
    assert written["bodies"][2]["origin"] == [5, -2, 1] and "rotation" not in written["bodies"][2]
    assert written["joints"][2]["axis2"] == [0, 1, 0]
    m2 = linkdyn.load(tmp_path / "again.toml")
    t = np.linspace(0.0, 0.5, 9)
    _same_columns(linkdyn.analyze(m, t).columns(), linkdyn.analyze(m2, t).columns())
    # and the unposed file's run: the pose is only a choice of body frames
    plain = linkdyn.load(linkdyn.example_path("rsur"))
    a, b = linkdyn.analyze(plain, t).columns(), linkdyn.analyze(m2, t).columns()
    for k in ("tau_J1", "Fx_J4", "Mz_J3", "x_coupler.C", "kinetic_energy"):
        scale = max(float(np.max(np.abs(a[k]))), 1e-12)
        np.testing.assert_allclose(b[k], a[k], rtol=0, atol=1e-9 * scale, err_msg=k)
