"""Forward dynamics of spatial models (``linkdyn simulate``, issue 24) against means that share
no code with it:

- the released RSUR four-bar (bundled ``rsur_release``), through the command line: its loops
  closed, read from results.csv's own points and quaternions; its energy recomputed here from
  the bodies' masses, inertias, points and rates (no projection onto the energy balance, so
  the balance is the integrator's alone); the independent Cartesian reference
  (tests/spatial_reference.py) driving the crank along the simulated motion's Taylor
  expansion needs no effort (the free acceleration solves the equations of motion);
- Hoeken's four-bar released in its plane (``fourbar_release``) written as a spatial model
  against the planar simulation;
- bad ``[initial]`` entries: exit 2 naming the field.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
import spatial_reference as ref
from linkdyn.cli import main
from linkdyn.errors import ModelError
from linkdyn.io import model_from_dict
from test_spatial import spatial_of_planar


def rotation(quat):
    """Rotation matrices (T, 3, 3) of unit quaternions (T, 4) [w, x, y, z]."""
    w, x, y, z = quat.T
    rows = ([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])
    return np.stack([np.stack(r, -1) for r in rows], -2)


def table(cols, body, name):
    return np.stack([cols[f"{c}_{body}.{name}"] for c in "xyz"], -1)


def energies(model, cols):
    """Kinetic and potential energy (T,) each, from the bodies' points, quaternions and angular
    velocities of a results table and the model's masses and inertias."""
    ke = pe = 0.0
    g = np.asarray(model.gravity)
    for b in model.bodies[1:]:
        R = rotation(np.stack([cols[f"quat_{c}_{b.name}"] for c in "wxyz"], -1))
        name, local = next(iter(b.points.items()))
        r, v = table(cols, b.name, name), np.stack([cols[f"v{c}_{b.name}.{name}"]
                                                     for c in "xyz"], -1)
        w = np.stack([cols[f"omega_{c}_{b.name}"] for c in "xyz"], -1)
        c = r + np.einsum("tij,j->ti", R, b.com - local)
        vc = v + np.cross(w, c - r)
        Iw = np.einsum("tij,jk,tlk,tl->ti", R, b.inertia, R, w)
        ke = ke + 0.5 * b.mass * np.sum(vc * vc, -1) + 0.5 * np.sum(w * Iw, -1)
        pe = pe - b.mass * (c @ g)
    return ke, pe


def test_rsur_release_closes_conserves_energy_and_needs_no_effort(tmp_path):
    path = linkdyn.example_path("rsur_release")
    res = CliRunner().invoke(main, ["simulate", str(path), "-o", str(tmp_path), "--duration",
                                    "0.2", "--samples", "3", "--rtol", "1e-10", "--atol",
                                    "1e-12", "--no-project"])
    assert res.exit_code == 0, res.output
    assert "energy balance drift" in res.output
    names = (tmp_path / "results.csv").read_text().splitlines()[0].split(",")
    cols = dict(zip(names, np.loadtxt(tmp_path / "results.csv", delimiter=",", skiprows=1).T))
    model = linkdyn.load(path)
    size = 0.2
    # the loops closed: J2 (spherical) and J3 (universal) points coincide, J3's axes square
    assert np.max(np.abs(table(cols, "crank", "B") - table(cols, "coupler", "B"))) < 1e-12 * size
    assert np.max(np.abs(table(cols, "rocker", "C") - table(cols, "coupler", "C"))) < 1e-12 * size
    j3 = model.joints[2]
    Rr = rotation(np.stack([cols[f"quat_{c}_rocker"] for c in "wxyz"], -1))
    Rc = rotation(np.stack([cols[f"quat_{c}_coupler"] for c in "wxyz"], -1))
    assert np.max(np.abs(np.einsum("tij,j,tik,k->t", Rr, j3.axis, Rc, j3.axis2))) < 1e-12
    # energy: constant to the integrator's tolerance, recomputed here
    ke, pe = energies(model, cols)
    assert np.max(ke) > 1e-3                                    # it moves
    assert np.allclose(ke, cols["kinetic_energy"], rtol=1e-12, atol=1e-15)
    assert np.max(np.abs(ke + pe - ke[0] - pe[0])) < 1e-8 * np.max(ke)
    assert np.all(cols["work"] == 0.0)
    # the reference drives J1 along the simulated motion's Taylor expansion at the last sample:
    # the effort vanishes against the gravity torque h (the same with no acceleration)
    t1 = float(cols["t"][-1])
    q, qd, qdd = (math.degrees(cols[f"{k}_J1"][-1]) for k in ("q", "qd", "qdd"))
    text = "\n".join(line for line in path.read_text().splitlines()
                     if not line.startswith(("[initial]", "q = { J1")))

    def effort(acc):
        file = tmp_path / "driven.toml"
        file.write_text(text + f"""
[[drivers]]
joint = "J1"
motion = {{ kind = "expression", q = "{q!r} + {qd!r}*(t - {t1!r}) + {acc / 2!r}*(t - {t1!r})**2" }}
""")
        return ref.run(file, [t1])["tau_J1"][0]
    assert abs(effort(qdd)) < 1e-8 * abs(effort(0.0))


def test_bricards_overconstrained_loop_moves_closed_and_conserves_energy(tmp_path):
    """IFToMM benchmark A04 (bundled ``bricard``): six revolute joints, Gruebler-Kutzbach 0, one
    degree of freedom by its geometry. ``check`` says so and names the redundant row; released
    at rest, the simulation (no projection onto the energy balance) keeps every joint's points
    together and axes in line (1e-12), its energy recomputed here from the bodies constant to
    1e-9 of the energy exchanged, and the Cartesian reference driving J1 along the simulated
    motion's Taylor expansion needs no effort (the free acceleration solves the equations of
    motion of the over-constrained loop)."""
    path = linkdyn.example_path("bricard")
    run = CliRunner().invoke
    res = run(main, ["check", str(path)])
    assert res.exit_code == 0, res.output
    assert "6*(6-1) - sum(6 - f)): 0" in res.output and "rank 4 of 5 rows): 1" in res.output
    assert "redundant constraint rows (1)" in res.output
    res = run(main, ["simulate", str(path), "-o", str(tmp_path), "--duration", "0.3",
                     "--samples", "4", "--rtol", "1e-10", "--atol", "1e-12", "--no-project",
                     "--backend", "numpy"])
    assert res.exit_code == 0, res.output
    names = (tmp_path / "results.csv").read_text().splitlines()[0].split(",")
    cols = dict(zip(names, np.loadtxt(tmp_path / "results.csv", delimiter=",", skiprows=1).T))
    model = linkdyn.load(path)
    for jt in model.joints:           # 1 m rods: closed to 1e-12 m and rad
        ends = [np.broadcast_to(model.body("ground").points[p], (4, 3)) if b == "ground"
                else table(cols, b, p) for b, p in ((jt.body_a, jt.point_a),
                                                    (jt.body_b, jt.point_b))]
        assert np.max(np.abs(ends[0] - ends[1])) < 1e-12, jt.name
        axes = [jt.axis if b == "ground" else np.einsum(
            "tij,j->ti", rotation(np.stack([cols[f"quat_{c}_{b}"] for c in "wxyz"], -1)),
            jt.axis) for b in (jt.body_a, jt.body_b)]
        assert np.max(np.abs(axes[0] - axes[1])) < 1e-12, jt.name
    ke, pe = energies(model, cols)
    assert np.ptp(pe) > 0.1                                    # it falls
    assert np.max(np.abs(ke + pe - ke[0] - pe[0])) < 1e-9 * np.ptp(pe)
    # P3 starts at (1, -1, 0) m and moves as the benchmark's figure shows it at first
    np.testing.assert_allclose(table(cols, "link2", "P3")[0], [1.0, -1.0, 0.0], atol=1e-15)
    assert np.all(np.diff(cols["x_link2.P3"]) < 0) and np.all(np.diff(cols["z_link2.P3"]) < 0)
    t1 = float(cols["t"][-1])
    q, qd, qdd = (math.degrees(cols[f"{k}_J1"][-1]) for k in ("q", "qd", "qdd"))
    text = "\n".join(line for line in path.read_text().splitlines()
                     if not line.startswith(("[initial]", "q = { J1")))

    def effort(acc):
        file = tmp_path / "driven.toml"
        file.write_text(text + f"""
[[drivers]]
joint = "J1"
motion = {{ kind = "expression", q = "{q!r} + {qd!r}*(t - {t1!r}) + {acc / 2!r}*(t - {t1!r})**2" }}
""")
        return ref.run(file, [t1])["tau_J1"][0]
    assert abs(effort(qdd)) < 1e-8 * abs(effort(0.0))


def test_planar_fourbar_released_in_space_moves_as_the_planar_simulation():
    planar = linkdyn.load(linkdyn.example_path("fourbar_release"))
    start = linkdyn.simulate(planar, np.zeros(1)).columns
    data, _ = spatial_of_planar("simulate/fourbar_release", start)
    data["initial"] = {"q": {"J1": 0.0}}                 # the design pose is the start
    model = model_from_dict(data)
    t = np.linspace(0.0, 0.06, 3)
    opts = dict(rtol=1e-12, atol=1e-14, backend="numpy")
    flat, space = linkdyn.simulate(planar, t, **opts).columns, linkdyn.simulate(model, t, **opts)
    cols = space.columns()
    for name in ("x_coupler.P", "y_coupler.P", "vx_coupler.P", "vy_coupler.P", "ax_rocker.O3",
                 "kinetic_energy", "qd_J1", "qdd_J3"):
        peak = np.max(np.abs(flat[name]))
        assert np.max(np.abs(cols[name] - flat[name])) < 1e-9 * peak, name
    assert np.max(np.abs(cols["z_coupler.P"])) < 1e-15
    assert np.max(np.abs(cols["q_J1"] + math.radians(30.0) - flat["q_J1"])) < 1e-9
    assert space.stats["closure_residual"] < 1e-12


@pytest.mark.parametrize("initial, field", [
    ({"q": {"J9": 1.0}}, "initial.q.J9"),
    ({"q": {"J2": 1.0}}, "initial.q.J2"),                   # spherical: no coordinates
    ({"q": {"J3": {"x": 1.0}}}, "initial.q.J3.x"),
    ({"q": {"J1": 1.0, "J4": 1.0}}, "initial.q"),           # one free freedom only
])
def test_bad_initial_names_the_field(initial, field):
    data = tomllib.loads(linkdyn.example_path("rsur_release").read_text())
    data["initial"] = initial
    with pytest.raises(ModelError) as err:
        linkdyn.simulate(model_from_dict(data), np.zeros(1))
    assert err.value.field == field


def spring_energy(model, cols):
    """The springs' potential (T,) and each damper's ``c (dl/dt)^2`` (T,), from the points'
    positions and velocities of a results table."""
    pe, dissipation = 0.0, 0.0
    for ld in model.loads:
        ends = []
        for body, point in ((ld.body, ld.point), (ld.body2, ld.point2)):
            if body == "ground":
                x = np.broadcast_to(model.body("ground").points[point], (len(cols["t"]), 3))
                ends.append((x, np.zeros_like(x)))
            else:
                ends.append((table(cols, body, point), np.stack(
                    [cols[f"v{c}_{body}.{point}"] for c in "xyz"], -1)))
        d, v = ends[1][0] - ends[0][0], ends[1][1] - ends[0][1]
        length = np.linalg.norm(d, axis=-1)
        if ld.kind == "spring":
            pe = pe + 0.5 * ld.stiffness * (length - ld.free_length) ** 2
        else:
            dissipation = dissipation + ld.damping * (np.sum(d * v, -1) / length) ** 2
    return pe, dissipation


def test_quarter_car_settles_at_its_static_equilibrium_with_the_damper_dissipating(tmp_path):
    path = linkdyn.example_path("quarter_car")
    model = linkdyn.load(path)
    t = np.linspace(0.0, 0.4, 161)
    sol = linkdyn.simulate(model, t, rtol=1e-5, backend="numpy")
    cols = sol.columns()
    assert sol.stats["closure_residual"] < 1e-12
    # the energy recomputed here: kinetic + gravity + springs changes by the work, which is
    # the damper's dissipation integrated here (Simpson's rule over the samples)
    ke, pe = energies(model, cols)
    pe_s, loss = spring_energy(model, cols)
    e = ke + pe + pe_s
    dt = t[1] - t[0]
    simpson = (loss[:-2:2] + 4 * loss[1:-1:2] + loss[2::2]) * dt / 3
    lost = np.concatenate(([0.0], np.cumsum(simpson)))
    assert cols["work"][-1] < 0 and e[-1] < e[0]            # the drop's energy is dissipated
    assert np.max(np.abs(e - e[0] - cols["work"])) < 1e-5 * abs(cols["work"][-1])
    assert np.max(np.abs(cols["work"][::2] + lost)) < 1e-4 * abs(cols["work"][-1])
    # the settled angle against the static equilibrium by the Cartesian reference: its effort
    # holding JL at rest vanishes there (secant iterations), the damper idle at rest
    text = path.read_text()
    damper, tyre = (text.index(f"[[loads]]\nkind = {x}")
                    for x in ('"damper"', '"spring"\nname = "tyre"'))
    text = "\n".join(line for line in (text[:damper] + text[tyre:]).splitlines()
                     if not line.startswith(("[initial]", "q = { JL")))

    def effort(deg):
        file = tmp_path / "held.toml"
        file.write_text(text + '\n[[drivers]]\njoint = "JL"\nmotion = { kind = "expression", '
                        f'q = "{deg!r} + 0*t" }}\n')
        return ref.run(file, [0.0])["tau_JL"][0]
    a, b = 0.0, -0.1
    fa, fb = effort(a), effort(b)
    for _ in range(6):
        a, b, fa = b, float(b - fb * (b - a) / (fb - fa)), fb
        fb = effort(b)
    settled = math.degrees(cols["q_JL"][-1])
    drop = math.degrees(cols["q_JL"][0]) - b
    assert abs(settled - b) < 1e-4 * drop, (settled, b)


def test_a_universal_joints_coordinate_as_the_free_one_and_compiled_refused():
    data = tomllib.loads(linkdyn.example_path("rsur_release").read_text())
    data["initial"] = {"q": {"J3": {"1": 0.0}}}             # "J3.1", the rocker's design pose
    model = model_from_dict(data)
    assert model.initial_q == {"J3.1": 0.0}
    sol = linkdyn.simulate(model, np.zeros(1))
    assert sol.free == ("J3.1",) and abs(sol.columns()["q_J3.1"][0]) < 1e-12
    with pytest.raises(ModelError) as err:
        linkdyn.simulate(model, np.zeros(1), backend="compiled")
    assert err.value.field == "backend"


def test_a_dead_point_of_the_free_coordinate_is_passed_by_switching_as_in_the_plane():
    """Hoeken's four-bar in space, pushed by a couple on the rocker from rest, integrated in
    the rocker's angle, which cannot describe the motion at the rocker's limits: the run
    switches to better-conditioned coordinates there (F10) and moves as the planar simulation
    integrated in the crank's angle throughout."""
    from test_simulate import pushed_rocker
    t = np.linspace(0.0, 0.26, 6)                       # the rocker's first limit at 0.243 s
    flat = linkdyn.simulate(pushed_rocker(q={"J1": 0.0}), t, rtol=1e-8, atol=1e-10).columns
    data, _ = spatial_of_planar("hoeken", {k: v[:1] for k, v in flat.items()})
    for key in ("drivers", "analysis"):
        data.pop(key, None)
    data["mechanism"]["gravity"] = [0.0, 0.0, 0.0]
    data["loads"] = [{"kind": "torque", "body": "rocker", "value": [0.0, 0.0, 2.0]}]
    data["initial"] = {"q": {"J4": 0.0}}
    sol = linkdyn.simulate(model_from_dict(data), t, rtol=1e-8, atol=1e-10, backend="numpy")
    assert sol.free == ("J4",) and len(sol.stats["switches"]) >= 1
    cols = sol.columns()
    for name in ("x_coupler.P", "vy_coupler.P", "qd_J1", "qd_J4", "work", "kinetic_energy"):
        peak = np.max(np.abs(flat[name]))
        assert np.max(np.abs(cols[name] - flat[name])) < 1e-7 * peak, name
    assert sol.stats["closure_residual"] < 1e-12 and sol.energy_drift < 1e-8
