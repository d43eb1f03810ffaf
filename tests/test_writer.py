"""linkdyn.save: every bundled example survives load -> save -> load (equal models, equal
analysis), in the file's units; what cannot be written says so."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

import linkdyn
from linkdyn import motion as motion_mod
from linkdyn.cli import example_names
from linkdyn.io.writer import model_to_dict


def assert_same(a, b, where="model"):
    """Recursive equality of models to a few ulp (unit conversions round)."""
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            if f.name in ("spline", "expr", "d1", "d2", "source"):  # derived, or the file's path
                continue
            assert_same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            assert_same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{k}]")
    elif isinstance(a, (np.ndarray, float, int)) and not isinstance(a, bool):
        np.testing.assert_allclose(b, a, rtol=1e-14, atol=1e-300, err_msg=where)
    elif callable(a) and hasattr(a, "components"):  # a load value
        assert_same(a.components, b.components, where)
    else:
        assert str(a) == str(b), where


@pytest.mark.parametrize("name", example_names())
def test_every_example_round_trips(name, tmp_path):
    m = linkdyn.load(linkdyn.example_path(name))
    m2 = linkdyn.load(linkdyn.save(m, tmp_path / f"{name}.toml"))
    assert_same(m, m2)
    t = np.linspace(0.0, 1.0, 25)
    a = linkdyn.analyze(m, t, allow_singular=True, backend="numpy").columns
    b = linkdyn.analyze(m2, t, allow_singular=True, backend="numpy").columns
    assert a.keys() == b.keys()
    for k in a:
        scale = max(float(np.nanmax(np.abs(a[k]), initial=0.0)), 1e-12)
        np.testing.assert_allclose(b[k], a[k], rtol=0, atol=1e-12 * scale, err_msg=k)


def test_keeps_the_files_units(tmp_path):
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    data = tomllib.loads(linkdyn.save(m, tmp_path / "h.toml").read_text())
    assert data["units"] == {"length": "mm", "angle": "deg"}
    assert data["bodies"][1]["points"]["O2"] == [38.1, 0]
    # the inertia about O1 in the file is written about the mass centre: 725.80 - 1.5 * 19.05^2
    assert data["bodies"][1]["inertia"] == pytest.approx(725.80 - 1.5 * 19.05 ** 2, rel=1e-13)
    assert data["drivers"][0]["motion"]["rpm"] == 45   # the file's own speed unit, exactly
    assert data["analysis"]["path_range"] == pytest.approx([110, 250], rel=1e-14)


@pytest.mark.parametrize("spec, key, value", [
    ("rpm = 120", "rpm", 120), ("speed = 720", "speed", 720), ("rpm = 45.5", "rpm", 45.5),
    ("speed = 0.3", "speed", 0.3), ("rpm = -33.3", "rpm", -33.3)])
def test_a_speed_is_written_in_the_unit_the_file_gave_it(tmp_path, spec, key, value):
    """Issue 23: ``rpm = 120`` was saved as ``speed = 719.9999999999999`` (deg/s). The speed
    comes back in its own unit, as the shortest number that reads back to the same SI speed."""
    text = linkdyn.example_path("hoeken").read_text()
    assert "rpm = 45.0" in text
    src = tmp_path / "m.toml"
    src.write_text(text.replace("rpm = 45.0", spec))
    m = linkdyn.load(src)
    data = tomllib.loads(linkdyn.save(m, tmp_path / "copy.toml").read_text())
    motion = data["drivers"][0]["motion"]
    assert motion[key] == value and ({"rpm", "speed"} - {key}).isdisjoint(motion)
    again = linkdyn.load(tmp_path / "copy.toml").drivers[0].motion
    assert again.speed == m.drivers[0].motion.speed   # the same SI speed, bit for bit


def test_table_motion_is_written_beside_the_model(tmp_path):
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, 2.0, 9)
    table = motion_mod.TableMotion(t, 30.0 * t ** 2, scale=np.pi / 180)
    m = dataclasses.replace(m, drivers=(dataclasses.replace(m.drivers[0], motion=table),),
                            cycles=None, duration=2.0)
    path = linkdyn.save(m, tmp_path / "tab.toml")
    assert (tmp_path / "tab.J1.csv").is_file()
    m2 = linkdyn.load(path)
    ts = np.linspace(0.0, 2.0, 17)
    for x, y in zip(m.drivers[0].motion.evaluate(ts), m2.drivers[0].motion.evaluate(ts)):
        np.testing.assert_allclose(y, x, rtol=1e-13, atol=1e-13)


def test_a_python_load_function_is_refused_with_a_reason():
    m = linkdyn.load(linkdyn.example_path("slider_crank"))
    load = dataclasses.replace(m.loads[0], value=lambda t: np.zeros(np.shape(t) + (2,)))
    with pytest.raises(ValueError, match="Python function"):
        model_to_dict(dataclasses.replace(m, loads=(load,)))
