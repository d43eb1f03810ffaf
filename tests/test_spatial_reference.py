"""Spatial mechanisms checked by means that share no code with linkdyn's spatial solver.

``spatial_reference`` (this folder) is an independent solver in Cartesian body coordinates (explicit
constraint equations, Newton positions, exact-bias rates, one minimum-norm Newton-Euler solve per
sample). Its self-tests run on any branch: its rates against finite differences of its positions,
power balance, closed forms (a driven pendulum about a skew axis, a screw-like redundant loop with
a cylindrical joint) and Hoeken's four-bar written spatially against linkdyn's planar solver. The
comparison tests (linkdyn's spatial solver against the reference on every bundled spatial example)
skip while linkdyn cannot load spatial models.
"""
from __future__ import annotations

import functools
import math
import re
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
import spatial_reference as ref
from linkdyn.cli import main

SPATIAL = ["hoeken_spatial", "rsur", "spherical_fourbar", "spatial_slider_crank", "rps3",
           "stewart"]
# fewer samples where the model is large (the Stewart platform: 13 moving bodies)
SAMPLES = {"stewart": 17}
HOEKEN_PERIOD = 60.0 / 45.0                  # s, 45 rpm
DEG = math.pi / 180.0
# the reference's own diagnostics, not contract columns
EXTRA = ("load_power", "ne_residual", "jacobian_rank", "jacobian_conditioning")


def example_times(name: str, n: int = 25) -> np.ndarray:
    """n samples over one crank turn (rps3: its 2 s run; stewart: its 1 s run, 17 samples)."""
    duration = {"hoeken_spatial": HOEKEN_PERIOD, "rps3": 2.0}.get(name, 1.0)   # 60 rpm: 1 s
    return np.linspace(0.0, duration, min(n, SAMPLES.get(name, n)))


@functools.lru_cache(maxsize=None)
def reference(name: str, n: int = 25) -> dict:
    """The reference's columns of a bundled spatial example (computed once per session)."""
    return ref.run(linkdyn.example_path(name), example_times(name, n))


# ------------------------------------------------------------------------- tolerances

def family(col: str) -> str:
    """A column's quantity less its component: vx_crank.B -> v, Fz_J1 -> F, omega_x_c -> omega."""
    head = col.split("_")[0]
    if head in ("x", "y", "z"):
        return "pos"
    if len(head) == 2 and head[1] in "xyz" and head[0] in "vaFM":
        return head[0]
    return "energy" if head in ("kinetic", "potential") else head


def family_peaks(cols: dict) -> dict:
    """Peak |value| of each family; moments at least forces times the mechanism's size."""
    peaks: dict[str, float] = {}
    for k, v in cols.items():
        peaks[family(k)] = max(peaks.get(family(k), 0.0), float(np.max(np.abs(v))))
    peaks["M"] = max(peaks.get("M", 0.0), peaks.get("F", 0.0) * peaks.get("pos", 0.0))
    return peaks


def mismatch(got: dict, want: dict, names=None, offsets=None, floor=1e-3) -> dict:
    """Per column: max |got - want| over the column's peak in want (at least floor times its
    family's peak, for columns that are zero in exact arithmetic)."""
    peaks = family_peaks(want)
    out = {}
    for k in names if names is not None else want:
        w = want[k] - (offsets or {}).get(k, 0.0)
        scale = max(float(np.max(np.abs(want[k]))), floor * peaks[family(k)])
        out[k] = float(np.max(np.abs(np.asarray(got[k]) - w))) / scale
    return out


def assert_close(got, want, rel, names=None, offsets=None, floor=1e-3):
    err = mismatch(got, want, names, offsets, floor)
    worst = sorted(err.items(), key=lambda kv: -kv[1] if np.isfinite(kv[1]) else -np.inf)[:5]
    bad = {k: v for k, v in err.items() if not v <= rel}          # NaN fails too
    assert not bad, f"columns off (error / peak): {sorted(bad.items())[:5]}; worst {worst}"


# ------------------------------------------------------------------------- examples bundled

def test_spatial_examples_are_bundled_and_listed():
    res = CliRunner().invoke(main, ["example", "--list"])
    assert res.exit_code == 0
    listed = {line.split()[0]: line for line in res.stdout.splitlines() if line.strip()}
    for name in SPATIAL:
        assert "(spatial)" in listed[name]
        text = CliRunner().invoke(main, ["example", name]).stdout
        assert text == linkdyn.example_path(name).read_text("utf-8")
        doc = tomllib.loads(text)
        assert doc["mechanism"]["space"] == "spatial" and doc["mechanism"]["description"]
        assert doc["mechanism"]["name"] in listed[name]


@pytest.mark.parametrize("name", SPATIAL)
def test_reference_assembles_and_moves_each_example_smoothly(name):
    """Every example closes at every sample (Newton-Euler residual at round-off), its joint
    coordinates move smoothly (steps under 0.6 rad or 0.6 m, each within a tenth of the largest
    step of its rates' trapezoid: no jump to another branch), the Jacobian with the drivers' rows
    keeps full column rank (6 per moving body: the drivers fix the motion) and its smallest
    singular value stays above 1e-3 of its largest (no singular position) over 25 samples
    (stewart: 17)."""
    cols = reference(name)
    assert np.max(cols["ne_residual"]) < 1e-9 * max(1.0, family_peaks(cols)["F"])
    dt = np.diff(cols["t"])
    for k, v in cols.items():
        if k.startswith("q_"):
            # each step as its rates' trapezoid predicts (a jump to another branch would not)
            qd = cols["qd_" + k[2:]]
            step = np.max(np.abs(np.diff(v)))
            assert step < 0.6, k
            assert np.max(np.abs(np.diff(v) - 0.5 * (qd[1:] + qd[:-1]) * dt)) < 0.1 * step, k
    assert set(cols["jacobian_rank"]) == {6 * len(ref.load(linkdyn.example_path(name)).bodies)}
    assert np.min(cols["jacobian_conditioning"]) > 1e-3


# ------------------------------------------------------------------------- reference self-tests

def fd_columns(path, base, h=1e-5):
    """The reference at base - h, base, base + h (continuation through them in time order)."""
    t = np.sort(np.concatenate([base - h, base, base + h]))
    return ref.run(path, t), h


def quaternion_omega(q, qdot):
    """Global angular velocity from a unit quaternion and its rate: 2 qdot (x) conj(q)."""
    w, v, wd, vd = q[:, 0], q[:, 1:], qdot[:, 0], qdot[:, 1:]
    return 2.0 * (w[:, None] * vd - wd[:, None] * v - np.cross(vd, v))


@pytest.mark.parametrize("name, base", [
    ("rsur", np.linspace(0.05, 0.95, 6)),
    ("spatial_slider_crank", np.linspace(0.05, 0.95, 6)),
    ("rps3", np.linspace(0.1, 1.9, 5))])
def test_reference_rates_are_derivatives_of_its_positions_and_power_balances(name, base):
    """Central differences (h = 1e-5 s): points, joint coordinates and quaternions against the
    velocity columns, velocities against accelerations; the drivers' power against
    dKE/dt - the loads' and gravity's power."""
    cols, h = fd_columns(linkdyn.example_path(name), base)
    mid = slice(1, None, 3)
    d = lambda k: (cols[k][2::3] - cols[k][0::3]) / (2 * h)
    fd, exact = {}, {}
    for k in cols:
        # each position-like column and the column of its rate
        rate = (("v" + k) if re.match(r"[xyz]_", k) else ("a" + k[1:]) if re.match(r"v[xyz]_", k)
                else ("qd_" + k[2:]) if k.startswith("q_") else ("qdd_" + k[3:])
                if k.startswith("qd_") else ("alpha_" + k[6:]) if k.startswith("omega_") else None)
        if rate is not None:
            fd[rate], exact[rate] = d(k), cols[rate][mid]
    for body in {k[len("quat_w_"):] for k in cols if k.startswith("quat_w_")}:
        q = np.stack([cols[f"quat_{c}_{body}"] for c in "wxyz"], axis=1)
        w = quaternion_omega(q[1::3], (q[2::3] - q[0::3]) / (2 * h))
        for i, c in enumerate("xyz"):
            fd[f"omega_{c}_{body}"] = w[:, i]
            exact[f"omega_{c}_{body}"] = cols[f"omega_{c}_{body}"][mid]
    assert len(fd) > 20
    assert_close(fd, exact, 1e-6, floor=1.0)     # differences' round-off: of the family's peak
    # power balance: sum(effort * qd) = dKE/dt - P_loads (gravity included)
    p_eff = sum(cols[k][mid] * cols["qd_" + k.split("_", 1)[1]][mid]
                for k in cols if k.startswith(("tau_", "force_")))
    dke = d("kinetic_energy")
    scale = np.max(np.abs(p_eff))
    assert scale > 0 and np.max(np.abs(p_eff - (dke - cols["load_power"][mid]))) < 1e-6 * scale


def test_reference_hoeken_spatial_equals_linkdyn_planar():
    """Hoeken's four-bar with all axes +z against linkdyn's planar solver on hoeken.toml: the
    joint coordinates (spatial ones are 0 at the design pose: the planar values less the
    written rotations), angles, rates, point paths, the driving torque and the in-plane
    reactions to 1e-9 of each column's peak; every out-of-plane component zero."""
    t = example_times("hoeken_spatial")
    cols = reference("hoeken_spatial")
    planar = linkdyn.analyze(linkdyn.load(linkdyn.example_path("hoeken")), t)
    p = planar.columns() if callable(planar.columns) else planar.columns
    design = {"q_J1": 0.0, "q_J2": 77.12 * DEG, "q_J3": -154.24 * DEG, "q_J4": -77.12 * DEG}
    got = dict(cols)
    for body in ("crank", "coupler", "rocker"):
        got["phi_" + body] = np.unwrap(2 * np.arctan2(cols["quat_z_" + body],
                                                      cols["quat_w_" + body]))
        got["omega_" + body] = cols["omega_z_" + body]
        got["alpha_" + body] = cols["alpha_z_" + body]
    names = [k for k in p if k != "t" and not k.startswith("power_")]
    assert {"tau_J1", "Fx_J4", "x_coupler.P", "ay_coupler.P", "kinetic_energy"} <= set(names)
    for k in names:
        if k.startswith("q_"):
            got[k] = cols[k] + design[k]
    assert_close(got, p, 1e-9, names)
    # out of the plane: positions, rates, reactions (moments against forces times the size)
    peaks = family_peaks(cols)
    for k, v in cols.items():
        if re.match(r"(z|vz|az|Fz|Mx|My|Mz)_|(omega|alpha|quat)_[xy]_", k):
            assert np.max(np.abs(v)) <= 1e-12 * peaks[family(k)], k


SKEW_PENDULUM = """
[mechanism]
name = "skew pendulum"
space = "spatial"
gravity = [0.0, 0.0, -9.81]
[units]
length = "mm"
angle = "deg"
[[bodies]]
name = "ground"
points = { O = [10.0, 20.0, 30.0] }
[[bodies]]
name = "bob"
origin = [10.0, 20.0, 30.0]
rotation = [10.0, -20.0, 30.0]
points = { O = [0.0, 0.0, 0.0], P = [120.0, 15.0, -40.0] }
mass = 1.2
com = [80.0, 10.0, -25.0]
inertia = [[900.0, 40.0, -30.0], [40.0, 1500.0, 60.0], [-30.0, 60.0, 1800.0]]
[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O", "bob.O"]
axis = [0.36, 0.48, 0.8]
[[drivers]]
joint = "J1"
motion = { kind = "expression", q = "40*sin(3*t) + 20*t" }
"""


def axis_angle_quaternion(v):
    """[w, x, y, z] of rotation vector v (rad)."""
    th = np.linalg.norm(v)
    axis = v / th if th > 0 else np.zeros(3)
    return np.concatenate([[np.cos(th / 2)], np.sin(th / 2) * axis])


def quaternion_product(a, b):
    """a (x) b: the rotation b, then a."""
    return np.concatenate([[a[0] * b[0] - a[1:] @ b[1:]],
                           a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:])])


def quaternion_matrix(q):
    """Rotation matrix of a unit quaternion [w, x, y, z]: (w^2 - v.v) I + 2 v v^T + 2 w [v]x."""
    w, v = q[0], q[1:]
    vx = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return (w * w - v @ v) * np.eye(3) + 2 * np.outer(v, v) + 2 * w * vx


def test_reference_skew_pendulum_closed_form(tmp_path):
    """A body driven about a skew axis through a fixed point O under gravity: Euler's equation
    about O, H_O' = I_O al + w x I_O w = M + tau e + d x m g, gives the torque (its component
    along e) and the reaction couple; F = m (a_c - g). Poses by quaternion products."""
    path = tmp_path / "pendulum.toml"
    path.write_text(SKEW_PENDULUM)
    t = np.linspace(0.0, 1.5, 13)
    cols = ref.run(path, t)
    mm, m, g = 1e-3, 1.2, np.array([0.0, 0.0, -9.81])
    O = np.array([10.0, 20.0, 30.0]) * mm
    e = np.array([0.36, 0.48, 0.8])
    th = (40 * np.sin(3 * t) + 20 * t) * DEG
    thd = (120 * np.cos(3 * t) + 20) * DEG
    thdd = -360 * np.sin(3 * t) * DEG
    q0 = axis_angle_quaternion(np.array([10.0, -20.0, 30.0]) * DEG)
    I_local = np.array([[900.0, 40.0, -30.0], [40.0, 1500.0, 60.0], [-30.0, 60.0, 1800.0]]) * mm**2
    want = {k: [] for k in ("q_J1", "qd_J1", "qdd_J1", "tau_J1", "kinetic_energy")}
    for k in range(len(t)):
        qt = quaternion_product(axis_angle_quaternion(th[k] * e), q0)
        qt = qt * np.sign(qt[0])
        R = quaternion_matrix(qt)
        d = R @ (np.array([80.0, 10.0, -25.0]) * mm)
        w, al = thd[k] * e, thdd[k] * e
        I_O = R @ I_local @ R.T + m * (d @ d * np.eye(3) - np.outer(d, d))
        H = I_O @ al + np.cross(w, I_O @ w)
        tau = e @ (H - np.cross(d, m * g))
        a_c = np.cross(al, d) + np.cross(w, np.cross(w, d))
        F = m * (a_c - g)
        M = H - np.cross(d, m * g) - tau * e
        P = R @ (np.array([120.0, 15.0, -40.0]) * mm)
        for i, c in enumerate("xyz"):
            for name, v in ((f"F{c}_J1", F), (f"M{c}_J1", M), (f"{c}_bob.P", O + P),
                            (f"v{c}_bob.P", np.cross(w, P)), (f"omega_{c}_bob", w),
                            (f"alpha_{c}_bob", al)):
                want.setdefault(name, []).append(v[i])
        for c, v in zip("wxyz", qt):
            want.setdefault(f"quat_{c}_bob", []).append(v)
        want["q_J1"].append(th[k])
        want["qd_J1"].append(thd[k])
        want["qdd_J1"].append(thdd[k])
        want["tau_J1"].append(tau)
        want["kinetic_energy"].append(0.5 * w @ I_O @ w)
    want = {k: np.array(v) for k, v in want.items()}
    assert_close(cols, want, 1e-10)


SCREW = """
[mechanism]
name = "turning sleeve on a driven carriage"
space = "spatial"
gravity = [0.0, 0.0, -9.81]
[units]
length = "mm"
angle = "deg"
[[bodies]]
name = "ground"
points = { O = [0.0, 0.0, 0.0] }
[[bodies]]
name = "carriage"
points = { O = [0.0, 0.0, 0.0] }
mass = 0.5
inertia = [50.0, 60.0, 70.0]
[[bodies]]
name = "sleeve"
points = { O = [0.0, 0.0, 0.0], P = [30.0, 0.0, 10.0] }
mass = 0.8
inertia = [[400.0, 30.0, -20.0], [30.0, 500.0, 40.0], [-20.0, 40.0, 600.0]]
[[joints]]
name = "P1"
type = "prismatic"
connect = ["ground.O", "carriage.O"]
axis = [0.48, 0.6, 0.64]
[[joints]]
name = "R1"
type = "revolute"
connect = ["carriage.O", "sleeve.O"]
axis = [0.48, 0.6, 0.64]
[[joints]]
name = "C1"
type = "cylindrical"
connect = ["ground.O", "sleeve.O"]
axis = [0.48, 0.6, 0.64]
[[drivers]]
joint = "P1"
motion = { kind = "expression", q = "30*sin(2*t)" }
[[drivers]]
joint = "R1"
motion = { kind = "expression", q = "90*t + 20*sin(4*t)" }
"""


def test_reference_cylindrical_redundant_loop_closed_form(tmp_path):
    """A sleeve turned by a revolute driver on a carriage slid by a prismatic driver, and also held
    by a cylindrical joint on the same axis e (Gruebler-Kutzbach -2, mobility 2): the cylindrical
    coordinates are the drivers' (travel s, turn phi), the efforts are (m_c + m_s)(s'' - g.e) and
    (e.I e) phi'' (a cylindrical joint carries no force nor couple along e), KE = (m_c + m_s) s'^2/2
    + (e.I e) phi'^2/2, and every reaction lies in its joint's constraint space."""
    path = tmp_path / "screw.toml"
    path.write_text(SCREW)
    t = np.linspace(0.0, 1.2, 9)
    cols = ref.run(path, t)
    e, g, m = np.array([0.48, 0.6, 0.64]), np.array([0.0, 0.0, -9.81]), 1.3
    I_e = e @ np.array([[400.0, 30.0, -20.0], [30.0, 500.0, 40.0], [-20.0, 40.0, 600.0]]) @ e * 1e-6
    s, sd, sdd = 30e-3 * np.sin(2 * t), 60e-3 * np.cos(2 * t), -120e-3 * np.sin(2 * t)
    ph = (90 * t + 20 * np.sin(4 * t)) * DEG
    phd, phdd = (90 + 80 * np.cos(4 * t)) * DEG, -320 * np.sin(4 * t) * DEG
    want = {"q_C1.s": s, "qd_C1.s": sd, "qdd_C1.s": sdd, "q_C1.r": ph, "qd_C1.r": phd,
            "qdd_C1.r": phdd, "q_P1": s, "q_R1": ph, "force_P1": m * (sdd - g @ e),
            "tau_R1": I_e * phdd, "kinetic_energy": 0.5 * m * sd**2 + 0.5 * I_e * phd**2}
    assert_close(cols, want, 1e-10)
    F = lambda j: np.stack([cols[f"F{c}_{j}"] for c in "xyz"], axis=1)
    M = lambda j: np.stack([cols[f"M{c}_{j}"] for c in "xyz"], axis=1)
    scale = np.max(np.abs(F("P1"))) + np.max(np.abs(F("C1")))
    for along in (F("P1") @ e, F("C1") @ e, M("C1") @ e, M("R1") @ e):
        assert np.max(np.abs(along)) < 1e-12 * scale


# -------------------------------------------------------------- linkdyn against the reference

def linkdyn_columns(name: str, t) -> dict:
    sol = linkdyn.analyze(linkdyn.load(linkdyn.example_path(name)), t)
    cols = sol.columns() if callable(sol.columns) else sol.columns
    return {k: np.asarray(v) for k, v in cols.items()}


@pytest.mark.parametrize("name", SPATIAL)
def test_linkdyn_spatial_equals_the_reference(name):
    """Every column the contract names (joint coordinates and rates, quaternions, angular rates,
    points and their rates, efforts, every reaction component, kinetic and potential energy) to
    1e-9 of each column's peak over 25 samples (stewart: 17)."""
    want = {k: v for k, v in reference(name).items() if k not in EXTRA and k != "t"}
    got = linkdyn_columns(name, example_times(name))
    assert not set(want) - set(got), f"missing columns: {sorted(set(want) - set(got))[:8]}"
    assert_close(got, want, 1e-9)


def test_linkdyn_hoeken_spatial_equals_linkdyn_planar():
    """linkdyn's spatial solve of hoeken_spatial against its planar solve of hoeken.toml: to 1e-12
    of each column's peak, out-of-plane reactions zero."""
    t = example_times("hoeken_spatial")
    s = linkdyn_columns("hoeken_spatial", t)
    planar = linkdyn.analyze(linkdyn.load(linkdyn.example_path("hoeken")), t)
    p = planar.columns() if callable(planar.columns) else planar.columns
    design = {"q_J1": 0.0, "q_J2": 77.12 * DEG, "q_J3": -154.24 * DEG, "q_J4": -77.12 * DEG}
    got = dict(s)
    for body in ("crank", "coupler", "rocker"):
        got["phi_" + body] = np.unwrap(2 * np.arctan2(s["quat_z_" + body], s["quat_w_" + body]))
        got["omega_" + body] = s["omega_z_" + body]
        got["alpha_" + body] = s["alpha_z_" + body]
    names = [k for k in p if k != "t" and not k.startswith("power_")]
    for k in names:
        if k.startswith("q_"):
            got[k] = s[k] + design[k]
    assert_close(got, p, 1e-12, names)
    fpeak = max(np.max(np.abs(p[k])) for k in p if k.startswith(("Fx_", "Fy_")))
    size = max(np.max(np.abs(p[k])) for k in p if k.startswith(("x_", "y_")))
    for j in ("J1", "J2", "J3", "J4"):
        assert np.max(np.abs(s["Fz_" + j])) <= 1e-12 * fpeak
        for c in "xyz":
            assert np.max(np.abs(s[f"M{c}_{j}"])) <= 1e-12 * fpeak * size


@pytest.mark.parametrize("name, gruebler, mobility", [
    ("hoeken_spatial", -2, 1), ("rsur", 1, 1), ("spherical_fourbar", -2, 1),
    ("spatial_slider_crank", 1, 1), ("rps3", 3, 3), ("stewart", 6, 6)])
def test_linkdyn_check_counts_and_names_the_redundant_rows(name, gruebler, mobility):
    """check: Gruebler-Kutzbach 6 (n - 1) - sum(6 - f) (hoeken_spatial: 6 x 3 - 4 x 5 = -2), the
    mobility from the Jacobian's rank, and the redundant rows named by joint where there are
    some (mobility - Gruebler-Kutzbach of them)."""
    res = CliRunner().invoke(main, ["check", str(linkdyn.example_path(name))])
    assert res.exit_code == 0, res.output
    out = res.output
    assert re.search(rf"Gr(ü|ue)bler[^\n]*:\s*{gruebler}\b", out), out
    assert re.search(rf"mobility[^\n]*rank[^\n]*:\s*{mobility}\b", out), out
    redundant = [ln for ln in out.splitlines() if ln.strip().lower().startswith("redundant")]
    if mobility > gruebler:
        assert redundant and re.search(r"\bJ[1-4]\b", " ".join(redundant)), out
    else:
        assert not redundant, out


@pytest.mark.parametrize("name, dimension", [("hoeken_spatial", 3), ("spherical_fourbar", 3),
                                             ("rsur", 0)])
def test_linkdyn_undetermined_reactions_span_the_references(name, dimension):
    """The redundancy linkdyn reports: its basis of the reactions statics leaves free spans the
    reference's null space (same orthogonal projector to 1e-9) at every sample; no redundancy
    where the reference finds none."""
    t = example_times(name, 7)
    mine = ref.undetermined_basis(ref.load(linkdyn.example_path(name)), t)
    assert {b.shape[1] for b in mine} == {dimension}
    sol = linkdyn.analyze(linkdyn.load(linkdyn.example_path(name)), t)
    if dimension == 0:
        assert sol.redundancy is None
        return
    theirs = np.asarray(sol.redundancy.basis)          # (T, 6 n_joints, k)
    for k, b in enumerate(mine):
        q, _ = np.linalg.qr(theirs[k])
        assert q.shape[1] == dimension
        assert np.max(np.abs(q @ q.T - b @ b.T)) < 1e-9


@pytest.mark.parametrize("text, duration", [(SKEW_PENDULUM, 1.5), (SCREW, 1.2)],
                         ids=["skew_pendulum", "cylindrical_screw"])
def test_linkdyn_closed_form_models_equal_the_reference(tmp_path, text, duration):
    """The closed-form models above (a body frame placed by origin and rotation; a redundant loop
    with a cylindrical joint and two expression drivers) through linkdyn: every column to 1e-9."""
    path = tmp_path / "model.toml"
    path.write_text(text)
    t = np.linspace(0.0, duration, 9)
    want = {k: v for k, v in ref.run(path, t).items() if k not in EXTRA and k != "t"}
    sol = linkdyn.analyze(linkdyn.load(path), t)
    got = sol.columns() if callable(sol.columns) else sol.columns
    assert not set(want) - set(got), f"missing columns: {sorted(set(want) - set(got))[:8]}"
    assert_close(got, want, 1e-9)


def test_linkdyn_spatial_api_gives_the_reference_numbers():
    """The Solution's arrays (the contract's Python API) against the reference's columns on rsur:
    effort, reaction (spherical: zero couple), point and its rates, omega, alpha, quaternion,
    rotation (the reference's quaternion turned into a matrix here), kinetic energy."""
    name = "rsur"
    want = reference(name)
    sol = linkdyn.analyze(linkdyn.load(linkdyn.example_path(name)), example_times(name))
    got = {"tau_J1": sol.effort("J1"), "kinetic_energy": sol.kinetic_energy()}
    for j in ("J1", "J2", "J3", "J4"):
        r = np.asarray(sol.reaction(j))
        assert r.shape == (len(sol.t), 6)
        for i, c in enumerate(("Fx", "Fy", "Fz", "Mx", "My", "Mz")):
            if c[0] == "F" or j != "J2":
                got[f"{c}_{j}"] = r[:, i]
        if j == "J2":                                    # spherical: no couple
            assert np.all(r[:, 3:] == 0.0)
    for body in ("crank", "coupler", "rocker"):
        for i, c in enumerate("xyz"):
            got[f"omega_{c}_{body}"] = sol.omega(body)[:, i]
            got[f"alpha_{c}_{body}"] = sol.alpha(body)[:, i]
        for i, c in enumerate("wxyz"):
            got[f"quat_{c}_{body}"] = sol.quaternion(body)[:, i]
        q = np.stack([want[f"quat_{c}_{body}"] for c in "wxyz"], axis=1)
        R = np.asarray(sol.rotation(body))
        assert np.max(np.abs(R - np.array([quaternion_matrix(x) for x in q]))) < 1e-9
    for i, c in enumerate("xyz"):
        got[f"{c}_coupler.C"] = sol.point("coupler", "C")[:, i]
        got[f"v{c}_coupler.C"] = sol.point_velocity("coupler", "C")[:, i]
        got[f"a{c}_coupler.C"] = sol.point_acceleration("coupler", "C")[:, i]
    assert_close(got, {k: v for k, v in want.items() if k not in EXTRA}, 1e-9, names=list(got))


def test_linkdyn_analyze_writes_the_reference_columns(tmp_path):
    """`linkdyn analyze spatial_slider_crank --samples 9`: results.csv holds every column the
    reference computes, equal to it at the file's own times (1e-9 of each column's peak)."""
    import csv
    out = tmp_path / "out"
    path = linkdyn.example_path("spatial_slider_crank")
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(out), "--samples", "9"])
    assert res.exit_code == 0, res.output
    with open(out / "results.csv", newline="") as f:
        rows = list(csv.reader(f))
    table = {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}
    assert len(table["t"]) == 9
    want = {k: v for k, v in ref.run(path, table["t"]).items()
            if k not in EXTRA and k != "t"}
    assert not set(want) - set(table), sorted(set(want) - set(table))[:8]
    assert_close(table, want, 1e-9)
