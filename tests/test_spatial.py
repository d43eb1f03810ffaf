"""Spatial mechanisms (issue 24): the solver of linkdyn.spatial against references that share
no code with it.

- Planar examples written as spatial models (all axes +z, design pose from the planar
  assembly) give the planar solver's columns to 1e-12 of each column's peak, and zero
  out-of-plane reactions (the planar solver shares no code with the spatial one).
- Genuinely spatial models (a slider-crank with spherical, universal and prismatic joints
  and a skew slide; an RSCR four-bar with a cylindrical joint): central differences of the
  positions, rotations and joint coordinates against the rates and accelerations; the power
  balance ``sum effort qd = dKE/dt + dPE/dt - (power of the other loads)`` with the energy
  recomputed here from the outputs; every body's Newton-Euler equations about its mass
  centre, written here from the reported reactions, efforts and loads; the reactions in each
  joint's constraint space and orthogonal to the undetermined basis (the minimum norm).
- A closed form: a body on one revolute joint about a skew axis, with a full inertia tensor.
- Bad input: exit 2 messages naming the field; exit 3 naming time and driver value.
"""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from linkdyn.errors import AssemblyError, ModelError
from linkdyn.io import model_from_dict

EXAMPLES = Path(linkdyn.__file__).parent / "examples"


# ---------------------------------------------------------------- helpers of the test
def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def spatial_of_planar(name: str, start: dict | None = None) -> tuple[dict, object]:
    """A planar example written as a spatial model: points and mass centres with z = 0,
    revolute axes +z, prismatic axes in the plane, inertia [I/2, I/2, I] about the mass
    centre, the design pose the planar assembly at t = 0 (or the columns ``start``); and the
    planar model."""
    data = tomllib.loads((EXAMPLES / f"{name}.toml").read_text())
    planar = linkdyn.load(EXAMPLES / f"{name}.toml")
    start = start or linkdyn.analyze(planar, np.zeros(1), backend="numpy").columns
    out = copy.deepcopy(data)
    out.pop("assembly", None)
    for key in ("path_point", "path_range"):       # no path straightness in space (yet)
        out.get("analysis", {}).pop(key, None)
    out["mechanism"]["space"] = "spatial"
    out["mechanism"]["gravity"] = list(data["mechanism"].get("gravity", [0, 0])) + [0.0]
    L = {"mm": 1e-3, "m": 1.0, "cm": 1e-2}[data.get("units", {}).get("length", "m")]
    deg = data.get("units", {}).get("angle", "rad") == "deg"
    for b, pb in zip(out["bodies"], planar.bodies):
        b["points"] = {k: list(v) + [0.0] for k, v in b["points"].items()}
        if b["name"] == "ground":
            continue
        b.pop("inertia_about", None)
        b["com"] = [float(x) for x in pb.com / L] + [0.0]
        ic = float(pb.inertia / L ** 2)
        b["inertia"] = [ic / 2, ic / 2, ic]
        phi = float(start[f"phi_{b['name']}"][0])
        p, local = next(iter(pb.points.items()))
        xy = np.array([start[f"x_{b['name']}.{p}"][0], start[f"y_{b['name']}.{p}"][0], 0.0])
        b["origin"] = [float(x) for x in (xy - rot_z(phi) @ np.r_[local, 0.0]) / L]
        b["rotation"] = [0.0, 0.0, math.degrees(phi) if deg else phi]
    for j in out["joints"]:
        j.pop("angle", None)
        j["axis"] = list(j["axis"]) + [0.0] if "axis" in j else [0.0, 0.0, 1.0]
    for load in out.get("loads", []):
        if load["kind"] == "force":
            load["value"] = list(load["value"]) + [0.0]
        elif load["kind"] == "torque":
            load["value"] = [0.0, 0.0, load["value"]]
    return out, planar


def moving(model):
    return [b for b in model.bodies if b.name != "ground"]


def central(x, t):
    """Central differences of x (T, ...) at the inner samples."""
    return (x[2:] - x[:-2]) / (t[2:] - t[:-2]).reshape((-1,) + (1,) * (x.ndim - 1))


def vee(m):
    return 0.5 * np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0],
                           m[..., 1, 0] - m[..., 0, 1]], -1)


def body_balances(model, sol):
    """Every moving body's Newton-Euler residuals about its mass centre (T, 6) written from
    the outputs alone: ``sum F + loads - m a_c`` and ``sum M_c + loads - (I a + w x I w)``;
    with the scale of the forces and moments."""
    out, scale = [], [1e-300, 1e-300]
    g = np.asarray(model.gravity)
    for b in moving(model):
        R = sol.rotation(b.name)
        c = sol.point(b.name, "G")
        ac = sol.point_acceleration(b.name, "G")
        w, a = sol.omega(b.name), sol.alpha(b.name)
        Ig = R @ b.inertia @ np.swapaxes(R, 1, 2)
        F = b.mass * g - b.mass * ac
        M = -(np.einsum("tij,tj->ti", Ig, a) + np.cross(w, np.einsum("tij,tj->ti", Ig, w)))
        for j in model.joints:
            if b.name not in (j.body_a, j.body_b):
                continue
            sign = 1.0 if b.name == j.body_b else -1.0
            r = sol.reaction(j.name)
            q = sol.point(j.body_b, j.point_b) if j.body_b != "ground" else None
            if q is None:
                q = np.broadcast_to(model.body("ground").points[j.point_b], c.shape)
            F = F + sign * r[:, :3]
            M = M + sign * (r[:, 3:] + np.cross(q - c, r[:, :3]))
            if j.name in [d.joint for d in model.drivers]:
                e = _axis(model, sol, j)
                tau = sol.effort(j.name)[:, None]
                if j.kind == "revolute":
                    M = M + sign * tau * e
                else:   # along the axis through B's point
                    F = F + sign * tau * e
                    M = M + sign * np.cross(q - c, tau * e)
        for load in model.loads:
            t = sol.t
            if load.kind == "force" and load.body == b.name:
                f = np.broadcast_to(load.value(t), c.shape)
                F = F + f
                M = M + np.cross(sol.point(b.name, load.point) - c, f)
            elif load.kind == "torque" and load.body == b.name:
                M = M + np.broadcast_to(load.value(t), c.shape)
            elif load.kind == "spring" and b.name in (load.body, load.body2):
                p1, p2 = _ends(model, sol, load)
                d = p2 - p1
                length = np.linalg.norm(d, axis=1)[:, None]
                f = load.stiffness * (length - load.free_length) * d / length
                here = p1 if b.name == load.body else p2
                f = f if b.name == load.body else -f
                F = F + f
                M = M + np.cross(here - c, f)
            elif load.kind == "joint_torque" and b.name in (load.body, load.body2):
                j = model.joint(load.joint)
                e = _axis(model, sol, j)
                M = M + (1.0 if b.name == j.body_b else -1.0) * value_of(model, sol, load)[:, None] * e
        out.append(np.concatenate([F, M], 1))
        scale[0] = max(scale[0], np.abs(b.mass * ac).max(), np.abs(b.mass * g).max())
        scale[1] = max(scale[1], scale[0] * _size(model))
    return out, scale


def value_of(model, sol, load):
    """A load's value at the samples, its formula fed the joints' reported coordinates."""
    cols = sol.columns()
    motion = ([cols.get("q_" + j.name) for j in model.joints],
              [cols.get("qd_" + j.name) for j in model.joints])
    return load.value(sol.t, motion)


def _size(model):
    pts = np.array([b.origin + b.rotation @ p for b in model.bodies for p in b.points.values()])
    return float(np.max(np.ptp(pts, axis=0)))


def _ends(model, sol, load):
    def at(body, point):
        if body == "ground":
            return np.broadcast_to(model.body("ground").points[point], (len(sol.t), 3))
        return sol.point(body, point)
    return at(load.body, load.point), at(load.body2, load.point2)


def _axis(model, sol, j):
    """A joint's axis in global components (turned with its first body)."""
    if j.body_a == "ground":
        return np.broadcast_to(j.axis, (len(sol.t), 3))
    return sol.rotation(j.body_a) @ j.axis


# ---------------------------------------------------------------- spatial test models
def slider_crank() -> dict:
    """Revolute crank about z, spherical crank pin, universal wrist pin (first body the rod,
    so the tree runs through it backwards), prismatic slider along a skew line; gravity, a
    spring, a force, a torque and a joint torque."""
    d = np.array([60.0, 10.0, 30.0])            # wrist pin B from crank pin A at the design pose
    ax = np.cross(d, [0.0, 0.0, 1.0])
    ax /= np.linalg.norm(ax)
    ax2 = np.cross(ax, d)
    ax2 /= np.linalg.norm(ax2)
    e = [1.0, 0.0, 0.3]
    return {
        "mechanism": {"name": "spatial slider-crank", "space": "spatial",
                      "gravity": [0.0, -3.0, -9.81]},
        "units": {"length": "mm", "angle": "deg"},
        "bodies": [
            {"name": "ground", "points": {"O": [0, 0, 0], "G": [80.0, 10.0, 30.0],
                                          "S": [0.0, 50.0, 0.0]}},
            {"name": "crank", "points": {"O": [0, 0, 0], "A": [20.0, 0, 0], "G": [10.0, 1.0, 2.0]},
             "mass": 0.3, "com": "G", "inertia": [[20.0, 1.0, -2.0], [1.0, 60.0, 3.0],
                                                  [-2.0, 3.0, 70.0]]},
            {"name": "rod", "origin": [20.0, 0, 0], "rotation": [10.0, -20.0, 5.0],
             "points": {"A": [0.0, 0.0, 0.0], "B": list(np.linalg.inv(_rv([10.0, -20.0, 5.0])) @ d),
                        "G": [30.0, 5.0, 10.0]},
             "mass": 0.5, "com": "G", "inertia": [150.0, 140.0, 20.0]},
            {"name": "slider", "origin": [80.0, 10.0, 30.0],
             "points": {"B": [0, 0, 0], "G": [5.0, 2.0, -1.0], "F": [10.0, 0.0, 0.0]},
             "mass": 0.8, "com": "G", "inertia": [30.0, 40.0, 50.0]},
        ],
        "joints": [
            {"name": "J1", "type": "revolute", "connect": ["ground.O", "crank.O"],
             "axis": [0.0, 0.0, 1.0]},
            {"name": "J2", "type": "spherical", "connect": ["crank.A", "rod.A"]},
            {"name": "J3", "type": "universal", "connect": ["rod.B", "slider.B"],
             "axis": list(np.linalg.inv(_rv([10.0, -20.0, 5.0])) @ ax), "axis2": list(ax2)},
            {"name": "J4", "type": "prismatic", "connect": ["ground.G", "slider.B"], "axis": e},
        ],
        "drivers": [{"joint": "J1", "motion": {"kind": "expression",
                                               "q": "40*sin(3*t) + 100*t**2"}}],
        "loads": [
            {"kind": "force", "body": "slider", "point": "F", "value": [-20.0, 5.0, "3*t"]},
            {"kind": "torque", "body": "rod", "value": [0.1, -0.2, 0.05]},
            {"kind": "spring", "body": "ground", "point": "S", "body2": "rod", "point2": "G",
             "stiffness": 0.5, "free_length": 30.0},
            {"kind": "joint_torque", "joint": "J1", "value": "-0.01*qd_J1"},
        ],
    }


def _rv(r_deg):
    from linkdyn.spatial.algebra import rotation_vector
    return rotation_vector(np.radians(r_deg))


def rscr() -> dict:
    """RSCR four-bar: revolute crank, spherical pin, cylindrical sleeve on a revolute rocker
    (a loop with a two-freedom tree joint)."""
    return {
        "mechanism": {"name": "RSCR", "space": "spatial", "gravity": [0.0, 0.0, -9.81]},
        "bodies": [
            {"name": "ground", "points": {"O": [0, 0, 0], "D": [0.6, 0.4, 0.5]}},
            {"name": "crank", "points": {"O": [0, 0, 0], "A": [0.2, 0, 0], "G": [0.1, 0, 0]},
             "mass": 1.0, "com": "G", "inertia": [0.001, 0.004, 0.004]},
            {"name": "coupler", "points": {"A": [0.2, 0, 0], "C": [0.6, 0.0, 0.5],
                                           "G": [0.4, 0.05, 0.25]},
             "mass": 2.0, "com": "G", "inertia": [0.05, 0.06, 0.02]},
            {"name": "rocker", "points": {"D": [0.6, 0.4, 0.5], "C": [0.6, 0.0, 0.5],
                                          "G": [0.6, 0.2, 0.5]},
             "mass": 1.5, "com": "G", "inertia": [0.02, 0.001, 0.02]},
        ],
        "joints": [
            {"name": "J1", "type": "revolute", "connect": ["ground.O", "crank.O"],
             "axis": [0.0, 0.0, 1.0]},
            {"name": "J2", "type": "spherical", "connect": ["crank.A", "coupler.A"]},
            {"name": "J3", "type": "cylindrical", "connect": ["rocker.C", "coupler.C"],
             "axis": [0.0, 1.0, 0.0]},
            {"name": "J4", "type": "revolute", "connect": ["ground.D", "rocker.D"],
             "axis": [1.0, 0.0, 0.0]},
        ],
        "drivers": [{"joint": "J1", "motion": {"kind": "expression", "q": "0.5*sin(2*t) + t"}}],
    }


@pytest.fixture(scope="module")
def solved():
    """The two spatial models, each also cut at its two-freedom joint, solved on 81 samples
    over 0.8 s."""
    t = np.linspace(0.0, 0.8, 81)
    out = {}
    for name, data, cut in (("slider_crank", slider_crank(), None), ("rscr", rscr(), None),
                            ("slider_crank_cut_universal", slider_crank(), ["J3"]),
                            ("rscr_cut_cylindrical", rscr(), ["J3"])):
        if cut:       # the spherical joint a tree joint (three Cardan angles), the other cut
            data["topology"] = {"cut": cut}
        model = model_from_dict(data)
        out[name] = (model, linkdyn.analyze(model, t))
    return out


# ---------------------------------------------------------------- planar as spatial
@pytest.mark.parametrize("name", ["hoeken", "slider_crank"])
def test_planar_example_as_spatial_gives_the_planar_results(name):
    data, planar = spatial_of_planar(name)
    spatial = model_from_dict(data)
    assert spatial.space == "spatial" and planar.space == "planar"
    t = np.linspace(0.0, 0.2, 41)
    ref = linkdyn.analyze(planar, t, backend="numpy").columns
    sol = linkdyn.analyze(spatial, t)
    got = sol.columns()
    family = {}
    for k, v in ref.items():
        family[k.split("_")[0]] = max(family.get(k.split("_")[0], 0.0), np.abs(v).max())
    # a moment's kind: the forces times the mechanism's size
    family["M"] = max(family.get("M", 0.0), max(family["Fx"], family["Fy"])
                      * max(family["x"], family["y"]))
    compared = 0
    for k, v in ref.items():
        mine = k.replace("M_", "Mz_") if k.startswith("M_") else k
        if mine not in got or k == "t":
            continue
        x = got[mine]
        if k.startswith("q_") and spatial.joint(k[2:]).kind == "revolute":
            x, v = x - x[0], v - v[0]       # spatial angles are 0 at the design pose
        # each column's peak; a column that is zero (a fixed point's) the peak of its kind
        peak, kind = np.abs(v).max(), family[k.split("_")[0]]
        scale = max(peak if peak > 1e-6 * kind else kind, 1e-300)
        assert np.abs(x - v).max() <= 1e-12 * scale, k
        compared += 1
    assert compared >= 6 * len(planar.joints)
    # nothing out of the plane, and the planar four revolute joints are redundant in space
    forces = max(np.abs(got[k]).max() for k in got if k.startswith(("Fx_", "Fy_")))
    for k in got:
        if k.startswith(("Fz_", "Mx_", "My_")):
            assert np.abs(got[k]).max() <= 1e-12 * forces, k
    assert sol.redundancy is not None and sol.redundancy.rows
    comps = set(sol.redundancy.components)
    assert comps and all(c.startswith(("Fz_", "Mx_", "My_")) for c in comps)


# ---------------------------------------------------------------- differences, energy
@pytest.mark.parametrize("name", ["slider_crank", "rscr", "slider_crank_cut_universal",
                                  "rscr_cut_cylindrical"])
def test_rates_and_accelerations_are_the_derivatives_of_the_positions(solved, name):
    model, sol = solved[name]
    t = sol.t
    for b in moving(model):
        R = sol.rotation(b.name)
        w_fd = vee(central(R, t) @ np.swapaxes(R[1:-1], 1, 2))
        w = sol.omega(b.name)
        assert np.abs(w_fd - w[1:-1]).max() <= 5e-3 * np.abs(w).max()
        a = sol.alpha(b.name)
        assert np.abs(central(w, t) - a[1:-1]).max() <= 5e-3 * np.abs(a).max()
        q = sol.quaternion(b.name)
        assert np.allclose(np.linalg.norm(q, axis=1), 1.0) and q[0, 0] >= 0
        assert np.abs(np.diff(q, axis=0)).max() < 0.2            # continuous
        w0, v = q[:, :1, None], q[:, 1:]                          # R = the quaternion's turn
        K = np.stack([np.cross(v, np.eye(3)[k]) for k in range(3)], -1)
        Rq = (np.eye(3) + 2 * w0 * K + 2 * K @ K)
        assert np.abs(Rq - R).max() < 1e-12
        for p in b.points:
            x, v, acc = (sol.point(b.name, p), sol.point_velocity(b.name, p),
                         sol.point_acceleration(b.name, p))
            sv, sa = max(np.abs(v).max(), 1e-9), max(np.abs(acc).max(), 1e-9)
            assert np.abs(central(x, t) - v[1:-1]).max() <= 5e-3 * sv, (b.name, p)
            assert np.abs(central(v, t) - acc[1:-1]).max() <= 5e-3 * sa, (b.name, p)
    cols = sol.columns()
    for k in cols:
        if k.startswith("q_"):
            rate, acc = cols["qd_" + k[2:]], cols["qdd_" + k[2:]]
            assert np.abs(central(cols[k], t) - rate[1:-1]).max() <= 5e-3 * np.abs(rate).max(), k
            assert np.abs(central(rate, t) - acc[1:-1]).max() <= 5e-3 * np.abs(acc).max(), k


@pytest.mark.parametrize("name", ["slider_crank", "rscr", "slider_crank_cut_universal",
                                  "rscr_cut_cylindrical"])
def test_power_balance(solved, name):
    """sum effort qd = dKE/dt + dPE/dt - power of the other loads, the energies from the
    outputs (mass centre velocities, angular velocities, rotations) recomputed here."""
    model, sol = solved[name]
    t = sol.t
    g = np.asarray(model.gravity)
    ke, pe = np.zeros(len(t)), np.zeros(len(t))
    other = np.zeros(len(t))
    for b in moving(model):
        R = sol.rotation(b.name)
        w = sol.omega(b.name)
        vc = sol.point_velocity(b.name, "G")
        Ig = R @ b.inertia @ np.swapaxes(R, 1, 2)
        ke += 0.5 * b.mass * np.sum(vc ** 2, 1) + 0.5 * np.einsum("ti,tij,tj->t", w, Ig, w)
        pe -= b.mass * sol.point(b.name, "G") @ g
    for load in model.loads:
        if load.kind == "force":
            other += np.sum(np.broadcast_to(load.value(t), (len(t), 3))
                            * sol.point_velocity(load.body, load.point), 1)
        elif load.kind == "torque":
            other += np.sum(np.broadcast_to(load.value(t), (len(t), 3))
                            * sol.omega(load.body), 1)
        elif load.kind == "spring":
            p1, p2 = _ends(model, sol, load)
            pe += 0.5 * load.stiffness * (np.linalg.norm(p2 - p1, axis=1) - load.free_length) ** 2
        elif load.kind == "joint_torque":
            other += value_of(model, sol, load) * sol.columns()["qd_" + load.joint]
    assert np.allclose(ke, sol.kinetic_energy(), rtol=1e-12, atol=1e-12 * ke.max())
    assert np.allclose(pe - pe[0], sol.potential_energy() - sol.potential_energy()[0],
                       rtol=0, atol=1e-10 * np.abs(pe).max())
    cols = sol.columns()
    driver = sum(cols[f"tau_{d.joint}"] * cols[f"qd_{d.joint}"] for d in model.drivers)
    lhs = driver[1:-1] + other[1:-1]
    rhs = central(ke + pe, t)
    assert np.abs(lhs - rhs).max() <= 2e-3 * np.abs(driver).max()


# ---------------------------------------------------------------- reactions
@pytest.mark.parametrize("name", ["slider_crank", "rscr", "slider_crank_cut_universal",
                                  "rscr_cut_cylindrical"])
def test_reactions_balance_every_body_in_the_constraint_spaces(solved, name):
    model, sol = solved[name]
    residuals, (fs, ms) = body_balances(model, sol)
    for r in residuals:
        assert np.abs(r[:, :3]).max() <= 1e-11 * fs
        assert np.abs(r[:, 3:]).max() <= 1e-11 * ms
    for j in model.joints:
        r = sol.reaction(j.name)
        e = _axis(model, sol, j)
        F, M = r[:, :3], r[:, 3:]
        big = max(np.abs(r).max(), 1e-300)
        if j.kind == "spherical":
            assert np.abs(M).max() <= 1e-12 * big
        if j.kind in ("revolute", "cylindrical"):
            assert np.abs(np.sum(M * e, 1)).max() <= 1e-12 * big
        if j.kind in ("prismatic", "cylindrical"):
            assert np.abs(np.sum(F * e, 1)).max() <= 1e-12 * big
        if j.kind == "universal":
            e2 = sol.rotation(j.body_b) @ j.axis2
            assert np.abs(np.sum(M * e, 1)).max() <= 1e-12 * big
            assert np.abs(np.sum(M * e2, 1)).max() <= 1e-12 * big


def test_redundant_reactions_are_the_minimum_norm_ones():
    """Hoeken's four-bar in space: each basis column of the undetermined reactions balances
    every body with no load (self-equilibrated), and the reported reactions, which balance
    every body, are orthogonal to the basis (so no other balancing set is shorter)."""
    data, _ = spatial_of_planar("hoeken")
    data["mechanism"]["gravity"] = [0.0, -9.81, -4.0]      # loads out of the plane too
    for b in data["bodies"]:
        if b["name"] != "ground":
            b["points"]["G"] = b["com"]
    model = model_from_dict(data)
    t = np.linspace(0.0, 0.3, 13)
    sol = linkdyn.analyze(model, t)
    residuals, (fs, ms) = body_balances(model, sol)
    for r in residuals:
        assert np.abs(r[:, :3]).max() <= 1e-11 * fs and np.abs(r[:, 3:]).max() <= 1e-11 * ms
    basis = sol.redundancy.basis
    assert basis.shape[2] == 3                 # GK -2 with mobility 1: three redundant rows
    stacked = np.stack([sol.reaction(j.name) for j in model.joints], 1).reshape(len(t), -1)
    assert np.abs(np.einsum("tik,ti->tk", basis, stacked)).max() <= 1e-12 * np.abs(stacked).max()
    # each basis column: zero net wrench on every moving body (no inertia, no load)
    for k in range(basis.shape[2]):
        col = basis[:, :, k].reshape(len(t), len(model.joints), 6)
        for b in moving(model):
            c = sol.point(b.name, "G")
            F, M = np.zeros_like(c), np.zeros_like(c)
            for jj, j in enumerate(model.joints):
                if b.name not in (j.body_a, j.body_b):
                    continue
                s = 1.0 if b.name == j.body_b else -1.0
                q = (sol.point(j.body_b, j.point_b))
                F += s * col[:, jj, :3]
                M += s * (col[:, jj, 3:] + np.cross(q - c, col[:, jj, :3]))
            assert np.abs(F).max() < 1e-12 and np.abs(M).max() < 1e-12 * _size(model) + 1e-12


# ---------------------------------------------------------------- closed form
def test_pendulum_about_a_skew_axis():
    """One body on a revolute joint about a skew axis, full inertia tensor, gravity:
    tau = I_axis qdd - e . (r x m g); the reaction F = m a_c - m g, M about the pivot from
    the angular momentum about the fixed pivot."""
    e = np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0)
    Ic = np.array([[0.3, 0.02, -0.01], [0.02, 0.2, 0.03], [-0.01, 0.03, 0.25]])
    data = {"mechanism": {"space": "spatial", "gravity": [0.0, 0.0, -9.81]},
            "bodies": [{"name": "ground", "points": {"P": [0.1, 0.2, 0.3]}},
                       {"name": "arm", "points": {"P": [0.1, 0.2, 0.3], "G": [0.5, -0.1, 0.2]},
                        "mass": 2.0, "com": "G", "inertia": Ic.tolist()}],
            "joints": [{"name": "J", "type": "revolute", "connect": ["ground.P", "arm.P"],
                        "axis": e.tolist()}],
            "drivers": [{"joint": "J", "motion": {"kind": "expression",
                                                  "q": "0.7*sin(2*t) + 0.4*t**2"}}]}
    model = model_from_dict(data)
    t = np.linspace(0.0, 2.0, 9)
    sol = linkdyn.analyze(model, t)
    assert sol.redundancy is None
    q = 0.7 * np.sin(2 * t) + 0.4 * t ** 2
    qd = 1.4 * np.cos(2 * t) + 0.8 * t
    qdd = -2.8 * np.sin(2 * t) + 0.8
    m, g = 2.0, np.array([0.0, 0.0, -9.81])
    K = np.array([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])
    R = np.eye(3) + np.sin(q)[:, None, None] * K + (1 - np.cos(q))[:, None, None] * (K @ K)
    r = R @ np.array([0.4, -0.3, -0.1])                  # mass centre from the pivot
    Ig = R @ Ic @ np.swapaxes(R, 1, 2)
    Ip = Ig + m * (np.sum(r * r, 1)[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :])
    I_axis = e @ Ic @ e + m * (0.4 ** 2 + 0.3 ** 2 + 0.1 ** 2 - (e @ [0.4, -0.3, -0.1]) ** 2)
    tau = I_axis * qdd - np.cross(r, m * g) @ e
    assert np.allclose(sol.effort("J"), tau, rtol=0, atol=1e-12 * np.abs(tau).max())
    w, al = qd[:, None] * e, qdd[:, None] * e
    ac = np.cross(al, r) + np.cross(w, np.cross(w, r))
    F = m * ac - m * g
    Mp = (np.einsum("tij,tj->ti", Ip, al) + np.cross(w, np.einsum("tij,tj->ti", Ip, w))
          - np.cross(r, m * g) - tau[:, None] * e)
    got = sol.reaction("J")
    assert np.allclose(got[:, :3], F, rtol=0, atol=1e-12 * np.abs(F).max())
    assert np.allclose(got[:, 3:], Mp, rtol=0, atol=1e-12 * np.abs(Mp).max())
    assert np.allclose(sol.columns()["q_J"], q, rtol=0, atol=1e-12)


# ---------------------------------------------------------------- input and failures
def _bad(mutate, field_part, words):
    data = slider_crank()
    mutate(data)
    with pytest.raises(ModelError) as err:
        model_from_dict(data, source="m.toml")
    text = str(err.value)
    assert field_part in text and words in text, text


def test_bad_spatial_input_names_field_and_fix():
    _bad(lambda d: d["bodies"][1]["points"].update(A=[20.0, 0.0]), "bodies.crank.points.A",
         "expected a vector [x, y, z] of 3 numbers")
    _bad(lambda d: d["joints"][0].pop("axis"), "joints.J1.axis", "needs its axis")
    _bad(lambda d: d["joints"][1].update(axis=[0, 0, 1]), "joints.J2.axis",
         "a spherical joint has no axis")
    _bad(lambda d: d["joints"][2].update(axis2=[1, 0, 0]), "joints.J3.axis2",
         "not perpendicular")
    _bad(lambda d: d["joints"][0].update(type="slot"), "joints.J1.type", "unknown spatial")
    _bad(lambda d: d["bodies"][2].update(inertia=[1.0, 1.0, 5.0]), "bodies.rod.inertia",
         "no rigid body has these moments")
    _bad(lambda d: d["bodies"][2].update(inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]),
         "bodies.rod.inertia", "not symmetric")
    _bad(lambda d: d.update(assembly={"phi": {}}), "assembly", "not read for spatial")
    _bad(lambda d: d["loads"][0].update(value=[1.0, 2.0]), "loads[0].value",
         "expected [fx, fy, fz]")
    _bad(lambda d: d["mechanism"].update(space="3d"), "mechanism.space", "unknown space")
    _bad(lambda d: d.update(analysis={"path_point": "rod.G"}), "analysis.path_point",
         "not yet for spatial models")
    _bad(lambda d: d.update(analysis={"output": ["x"]}), "analysis.output",
         "not yet for spatial models")
    _bad(lambda d: d["loads"].append({"kind": "friction", "joint": "J1", "coefficient": 0.1,
                                      "radius": 5.0}), "loads", "not yet for spatial models")


def test_a_loop_that_cannot_close_stops_with_time_and_driver_value():
    data = rscr()
    data["drivers"][0]["motion"] = {"kind": "expression", "q": "4*t"}
    data["bodies"][3]["points"]["D"] = [0.6, 0.2, 1.0]
    data["bodies"][0]["points"]["D"] = [0.6, 0.2, 1.0]
    model = model_from_dict(data, source="rscr.toml")
    with pytest.raises(AssemblyError) as err:
        linkdyn.analyze(model, np.linspace(0.0, 1.5, 31))
    assert "at t = " in str(err.value) and "q_J1 = " in str(err.value)


def test_cli_check_and_analyze_on_a_spatial_model(tmp_path):
    import json
    from linkdyn.io.writer import dumps_toml
    data, _ = spatial_of_planar("hoeken")
    data["analysis"] = {"duration": 0.1, "samples": 5}
    path = tmp_path / "h.toml"
    path.write_text(dumps_toml(data))
    run = CliRunner().invoke
    res = run(main, ["check", str(path)])
    assert res.exit_code == 0, res.output
    assert "Grübler–Kutzbach" in res.output and ": -2" in res.output
    assert "rank 2 of 5 rows): 1" in res.output and "redundant constraint rows (3)" in res.output
    assert "assembles at t = 0 and over the run (5 samples" in res.output
    res = run(main, ["analyze", str(path), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["mobility"] == 1 and summary["mobility_gruebler"] == -2
    assert summary["redundancy"]["undetermined_dimension"] == 3
    header = (tmp_path / "out" / "results.csv").read_text().splitlines()[0].split(",")
    assert {"quat_w_crank", "omega_z_rocker", "tau_J1", "Mz_J4", "z_coupler.P"} <= set(header)
    model = linkdyn.load(path)
    with pytest.raises(ModelError, match="not yet for spatial models"):
        linkdyn.analyze([model, model], [0.0])
    for command in (["simulate", str(path), "--format", "parquet"], ["analyze", str(path), "--path-point", "coupler.P"]):
        res = run(main, command)
        assert res.exit_code == 2 and "not yet for spatial models" in res.output, command


# a slider-crank driven by its slider, crank and rod in line at t = 0 (a dead centre)
DEAD_CENTRE = {"mechanism": {"space": "spatial"},
        "bodies": [{"name": "ground", "points": {"O": [0, 0, 0]}},
                   {"name": "crank", "points": {"O": [0, 0, 0], "A": [0.1, 0, 0]},
                    "mass": 1.0, "inertia": [0.001, 0.001, 0.001]},
                   {"name": "rod", "points": {"A": [0.1, 0, 0], "B": [0.4, 0, 0]},
                    "mass": 1.0, "inertia": [0.001, 0.001, 0.001]},
                   {"name": "slider", "points": {"B": [0.4, 0, 0]},
                    "mass": 1.0, "inertia": [0.001, 0.001, 0.001]}],
        "joints": [{"name": "J1", "type": "revolute", "connect": ["ground.O", "crank.O"],
                    "axis": [0, 0, 1]},
                   {"name": "J2", "type": "revolute", "connect": ["crank.A", "rod.A"],
                    "axis": [0, 0, 1]},
                   {"name": "J3", "type": "revolute", "connect": ["rod.B", "slider.B"],
                    "axis": [0, 0, 1]},
                   {"name": "J4", "type": "prismatic", "connect": ["ground.O", "slider.B"],
                    "axis": [1, 0, 0]}],
        "drivers": [{"joint": "J4", "motion": {"kind": "expression", "q": "0.4 - t**2"}}]}


def test_a_dead_centre_is_a_singular_position():
    """A slider-crank driven by its slider from the dead centre (crank and rod in line): the
    dependent joints' Jacobian has lost rank there (exit 3 at t = 0)."""
    data = DEAD_CENTRE
    with pytest.raises(AssemblyError, match="singular position") as err:
        linkdyn.analyze(model_from_dict(data), np.linspace(0.0, 0.2, 5))
    assert "at t = 0 s" in str(err.value) and "q_J4 = 0.4" in str(err.value)


@pytest.mark.parametrize("name", ["slider_crank", "rscr"])
def test_the_cut_joint_does_not_change_the_results(solved, name):
    """Cut at the spherical joint or at the two-freedom joint (the spherical one then a tree
    joint of three Cardan angles): other trees, other closure rows, the same mechanism."""
    a = solved[name][1].columns()
    b = solved[{"slider_crank": "slider_crank_cut_universal",
                "rscr": "rscr_cut_cylindrical"}[name]][1].columns()
    assert set(a) == set(b)
    family = {}
    for k, v in a.items():      # a column's kind: its name up to "_" (Mz, vx, quat, ...)
        family[k.split("_")[0]] = max(family.get(k.split("_")[0], 0.0), np.abs(v).max())
    for k in a:
        peak, kind = np.abs(a[k]).max(), family[k.split("_")[0]]
        scale = max(peak if peak > 1e-6 * kind else kind, 1e-300)     # a zero column: its kind's
        assert np.abs(a[k] - b[k]).max() <= 1e-9 * scale, k


def test_a_wholly_redundant_loop():
    """A sleeve turned and slid by two drivers (prismatic then revolute, one axis) and also held
    by a cylindrical joint on that axis: the cut joint's four rows are all redundant (its
    Jacobian is round-off alone), mobility 2; the reactions still balance every body and the
    cylindrical joint's share is the minimum-norm one."""
    e = [0.48, 0.6, 0.64]
    data = {"mechanism": {"space": "spatial", "gravity": [0.0, 0.0, -9.81]},
            "bodies": [{"name": "ground", "points": {"O": [0, 0, 0]}},
                       {"name": "carriage", "points": {"O": [0, 0, 0], "G": [0.01, 0.0, 0.02]},
                        "mass": 0.5, "com": "G", "inertia": [0.05, 0.06, 0.07]},
                       {"name": "sleeve", "points": {"O": [0, 0, 0], "G": [0.03, 0.0, 0.01]},
                        "mass": 0.8, "com": "G",
                        "inertia": [[0.4, 0.03, -0.02], [0.03, 0.5, 0.04], [-0.02, 0.04, 0.6]]}],
            "joints": [{"name": "P1", "type": "prismatic", "connect": ["ground.O", "carriage.O"],
                        "axis": e},
                       {"name": "R1", "type": "revolute", "connect": ["carriage.O", "sleeve.O"],
                        "axis": e},
                       {"name": "C1", "type": "cylindrical", "connect": ["ground.O", "sleeve.O"],
                        "axis": e}],
            "drivers": [{"joint": "P1", "motion": {"kind": "expression", "q": "0.03*sin(2*t)"}},
                        {"joint": "R1", "motion": {"kind": "expression", "q": "t**2"}}]}
    model = model_from_dict(data)
    sol = linkdyn.analyze(model, np.linspace(0.0, 1.2, 9))
    assert set(sol.redundancy.rows) == {"C1.F1", "C1.F2", "C1.M1", "C1.M2"}
    residuals, (fs, ms) = body_balances(model, sol)
    for r in residuals:
        assert np.abs(r[:, :3]).max() <= 1e-11 * fs and np.abs(r[:, 3:]).max() <= 1e-11 * ms
    # the sleeve's load shared between the carriage's path and the cut: the minimum norm
    stacked = np.stack([sol.reaction(j.name) for j in model.joints], 1).reshape(9, -1)
    basis = sol.redundancy.basis
    assert np.abs(np.einsum("tik,ti->tk", basis, stacked)).max() <= 1e-12 * np.abs(stacked).max()


def test_a_driven_joint_written_the_other_way_round():
    """The skew pendulum's joint written [arm, ground] (the tree then places its child from the
    joint's second body) with the opposite motion: the same motion of the arm, the effort and
    the reaction (now by the arm on the ground) reversed."""
    e = (np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0)).tolist()

    def model(reverse):
        return model_from_dict({
            "mechanism": {"space": "spatial", "gravity": [0.0, 0.0, -9.81]},
            "bodies": [{"name": "ground", "points": {"P": [0.1, 0.2, 0.3]}},
                       {"name": "arm", "points": {"P": [0.1, 0.2, 0.3], "G": [0.5, -0.1, 0.2]},
                        "mass": 2.0, "com": "G",
                        "inertia": [[0.3, 0.02, -0.01], [0.02, 0.2, 0.03], [-0.01, 0.03, 0.25]]}],
            "joints": [{"name": "J", "type": "revolute", "axis": e,
                        "connect": ["arm.P", "ground.P"] if reverse else ["ground.P", "arm.P"]}],
            "drivers": [{"joint": "J", "motion": {"kind": "expression", "q": (
                "-(0.7*sin(2*t) + 0.4*t**2)" if reverse else "0.7*sin(2*t) + 0.4*t**2")}}]})

    t = np.linspace(0.0, 2.0, 9)
    a, b = linkdyn.analyze(model(False), t), linkdyn.analyze(model(True), t)
    assert np.abs(a.point("arm", "G") - b.point("arm", "G")).max() < 1e-14
    assert np.abs(a.effort("J") + b.effort("J")).max() <= 1e-12 * np.abs(a.effort("J")).max()
    assert np.abs(a.reaction("J") + b.reaction("J")).max() <= 1e-12 * np.abs(a.reaction("J")).max()
