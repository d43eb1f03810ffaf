"""An independent reference for spatial mechanisms: Cartesian body coordinates, explicit
constraint equations and one simultaneous Newton-Euler solve per sample.

It shares no code with linkdyn: it reads the TOML model itself (``tomllib``), converts the units,
poses every moving body by its global position ``r`` (m) and rotation matrix ``R`` (body frame to
global), and writes each joint's constraint equations on those poses. Positions come from Newton's
method (minimum-norm steps, so redundant rows are harmless) with continuation over the samples,
velocities and accelerations from the constraint Jacobian ``J`` (columns ``[dr_i, dtheta_i]`` per
moving body, ``dtheta`` a global rotation-vector increment) and the exact bias ``gamma``:

    Phi(x, t) = 0,    J xdot = nu(t),    J xddot = eta(t) - gamma(x, xdot).

The efforts and reactions solve every moving body's six Newton-Euler equations about its mass
centre (global components) at once, the unknowns being each joint's reaction wrench (by A on B, at
B's point q) in an orthonormal basis of the joint's constraint space and the drivers' efforts; the
reaction vector is the minimum-Euclidean-norm solution, efforts not in the norm (they are
projected out first). This is the definition of the spatial contract.

Supported: joints revolute, prismatic, cylindrical, universal, spherical; drivers constant_speed
(speed or rpm) and expression (``+ - * /``, ``**`` with a constant exponent, ``sin cos tan exp
sqrt``, ``pi``, ``e``, ``t``; parsed with ``ast`` and evaluated with second-order jets, never
executed); loads force and torque (constant 3-vectors), spring; gravity.
"""
from __future__ import annotations

import ast
import math
import tomllib
from dataclasses import dataclass, field

import numpy as np

ZERO = np.zeros(3)
LENGTH = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": 0.0254}
ANGLE = {"rad": 1.0, "deg": math.pi / 180.0}


# ------------------------------------------------------------------------- rotations

def cross(a, b):
    """a x b of two 3-vectors (numpy's cross is slow on single vectors)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def skew(v):
    """[v]x, (3, 3)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rotvec_matrix(v):
    """Rodrigues: the rotation matrix of rotation vector v (rad)."""
    v = np.asarray(v, float)
    th = np.linalg.norm(v)
    if th < 1e-300:
        return np.eye(3)
    k = skew(v / th)
    return np.eye(3) + math.sin(th) * k + (1.0 - math.cos(th)) * (k @ k)


def perpendiculars(a):
    """Two unit vectors u, w with (a, u, w) right-handed orthonormal."""
    a = a / np.linalg.norm(a)
    trial = np.eye(3)[np.argmin(np.abs(a))]
    u = cross(a, trial)
    u /= np.linalg.norm(u)
    return u, cross(a, u)


def quaternion(R):
    """Unit quaternion [w, x, y, z] of a rotation matrix (Shepperd)."""
    tr = np.trace(R)
    cands = [1.0 + tr, 1.0 + 2 * R[0, 0] - tr, 1.0 + 2 * R[1, 1] - tr, 1.0 + 2 * R[2, 2] - tr]
    k = int(np.argmax(cands))
    s = math.sqrt(cands[k]) * 2.0
    if k == 0:
        q = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        q = [(R[2, 1] - R[1, 2]) / s, s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s]
    else:
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4]
    return np.array(q)


def signed_angle(x, y, a):
    """Angle turning unit vector x to y about unit axis a (both perpendicular to a), rad."""
    return math.atan2(np.dot(cross(x, y), a), np.dot(x, y))


# ------------------------------------------------------------------------- expressions

class Jet:
    """A value with its first and second time derivatives (arrays over t)."""

    def __init__(self, v, d=0.0, dd=0.0):
        self.v, self.d, self.dd = v, d, dd

    def __add__(self, o):
        return Jet(self.v + o.v, self.d + o.d, self.dd + o.dd)

    def __sub__(self, o):
        return Jet(self.v - o.v, self.d - o.d, self.dd - o.dd)

    def __mul__(self, o):
        return Jet(self.v * o.v, self.d * o.v + self.v * o.d,
                   self.dd * o.v + 2 * self.d * o.d + self.v * o.dd)

    def __truediv__(self, o):
        return self * o.apply(lambda x: 1 / x, lambda x: -1 / x**2, lambda x: 2 / x**3)

    def __neg__(self):
        return Jet(-self.v, -self.d, -self.dd)

    def apply(self, f, f1, f2):
        """Chain rule for f(self): (f(u), f'(u) u', f''(u) u'^2 + f'(u) u'')."""
        return Jet(f(self.v), f1(self.v) * self.d, f2(self.v) * self.d**2 + f1(self.v) * self.dd)

    def __pow__(self, o):
        if not (np.ndim(o.v) == 0 and np.ndim(o.d) == 0 and o.d == 0 and o.dd == 0):
            raise ValueError("the reference evaluates powers with constant exponents only")
        n = float(o.v)                                            # u**n, n constant
        return self.apply(lambda x: x**n, lambda x: n * x**(n - 1),
                          lambda x: n * (n - 1) * x**(n - 2))


FUNCS = {
    "sin": (np.sin, np.cos, lambda x: -np.sin(x)),
    "cos": (np.cos, lambda x: -np.sin(x), lambda x: -np.cos(x)),
    "tan": (np.tan, lambda x: 1 / np.cos(x)**2, lambda x: 2 * np.tan(x) / np.cos(x)**2),
    "exp": (np.exp, np.exp, np.exp),
    "sqrt": (np.sqrt, lambda x: 0.5 / np.sqrt(x), lambda x: -0.25 * x**-1.5),
}


def expression_jet(text: str, t):
    """q, qd, qdd of a formula in t (s), evaluated by walking its syntax tree."""
    t = np.asarray(t, float)

    def walk(node):
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return Jet(float(node.value))
        if isinstance(node, ast.Name):
            if node.id == "t":
                return Jet(t, np.ones_like(t), np.zeros_like(t))
            if node.id in ("pi", "e"):
                return Jet(math.pi if node.id == "pi" else math.e)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            x = walk(node.operand)
            return -x if isinstance(node.op, ast.USub) else x
        if isinstance(node, ast.BinOp):
            ops = {ast.Add: Jet.__add__, ast.Sub: Jet.__sub__, ast.Mult: Jet.__mul__,
                   ast.Div: Jet.__truediv__, ast.Pow: Jet.__pow__}
            if type(node.op) in ops:
                return ops[type(node.op)](walk(node.left), walk(node.right))
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id in FUNCS and len(node.args) == 1):
            return walk(node.args[0]).apply(*FUNCS[node.func.id])
        raise ValueError(f"the reference does not evaluate {ast.dump(node)}")

    j = walk(ast.parse(text, mode="eval"))
    return tuple(np.broadcast_to(np.asarray(x, float), t.shape).copy() for x in (j.v, j.d, j.dd))


# ------------------------------------------------------------------------- model

@dataclass
class Body:
    name: str
    points: dict                      # name -> (3,) body frame, m
    r0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    R0: np.ndarray = field(default_factory=lambda: np.eye(3))
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))   # about com, body frame


@dataclass
class Joint:
    name: str
    kind: str
    a: int                            # body index (-1 ground)
    p: np.ndarray                     # in A's frame
    b: int
    q: np.ndarray                     # in B's frame
    axis: np.ndarray | None = None    # unit, A's frame
    axis2: np.ndarray | None = None   # unit, B's frame (universal)


@dataclass
class Driver:
    joint: int
    motion: object                    # callable t -> (q, qd, qdd) SI


@dataclass
class Model:
    bodies: list
    ground: Body
    joints: list
    drivers: list
    loads: list
    gravity: np.ndarray
    analysis: dict


def load(path) -> Model:
    """Read a spatial model file into SI quantities."""
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    units = doc.get("units", {})
    L = LENGTH[units.get("length", "m")]
    A = ANGLE[units.get("angle", "rad")]
    vec = lambda v: np.asarray(v, float) * L
    ground, bodies = None, []
    for b in doc["bodies"]:
        pts = {k: vec(v) for k, v in b.get("points", {}).items()}
        if b["name"] == "ground":                      # its frame is the global frame
            ground = Body(b["name"], pts)
            continue
        inertia = np.asarray(b.get("inertia", [0.0, 0.0, 0.0]), float) * L**2
        bodies.append(Body(b["name"], pts, vec(b.get("origin", [0, 0, 0])),
                           rotvec_matrix(np.asarray(b.get("rotation", [0, 0, 0]), float) * A),
                           float(b["mass"]), vec(b.get("com", [0, 0, 0])),
                           np.diag(inertia) if inertia.ndim == 1 else inertia))
    index = {b.name: i for i, b in enumerate(bodies)}
    index[ground.name] = -1
    allb = {**{b.name: b for b in bodies}, ground.name: ground}

    joints = []
    for j in doc["joints"]:
        (an, ap), (bn, bq) = (c.split(".") for c in j["connect"])
        unit = lambda v: np.asarray(v, float) / np.linalg.norm(v)
        joints.append(Joint(j["name"], j["type"], index[an], allb[an].points[ap],
                            index[bn], allb[bn].points[bq],
                            unit(j["axis"]) if "axis" in j else None,
                            unit(j["axis2"]) if "axis2" in j else None))
    jindex = {j.name: k for k, j in enumerate(joints)}

    drivers = []
    for d in doc.get("drivers", []):
        k = jindex[d["joint"]]
        m = d["motion"]
        scale = A if joints[k].kind == "revolute" else L
        if m["kind"] == "constant_speed":
            w = m["rpm"] * 2 * math.pi / 60 if "rpm" in m else m["speed"] * scale
            q0 = m.get("start", 0.0) * scale
            fn = (lambda t, q0=q0, w=w: (q0 + w * np.asarray(t, float),
                                         np.full(np.shape(t), w), np.zeros(np.shape(t))))
        elif m["kind"] == "expression":
            fn = (lambda t, text=m["q"], s=scale:
                  tuple(s * x for x in expression_jet(text, t)))
        else:
            raise ValueError(f"the reference has no driver kind {m['kind']}")
        drivers.append(Driver(k, fn))

    loads = []
    for ld in doc.get("loads", []):
        ld = dict(ld)
        ld["b"] = index[ld["body"]]
        if ld["kind"] == "force":
            ld["s"] = allb[ld["body"]].points[ld["point"]]
            ld["value"] = np.asarray(ld["value"], float)
        elif ld["kind"] == "torque":
            ld["value"] = np.asarray(ld["value"], float)
        elif ld["kind"] == "spring":
            ld["s"] = allb[ld["body"]].points[ld["point"]]
            ld["b2"] = index[ld["body2"]]
            ld["s2"] = allb[ld["body2"]].points[ld["point2"]]
            ld["k"] = ld["stiffness"] / L
            ld["l0"] = ld["free_length"] * L
        else:
            raise ValueError(f"the reference has no load kind {ld['kind']}")
        loads.append(ld)
    g = np.asarray(doc["mechanism"].get("gravity", [0, 0, 0]), float)
    return Model(bodies, ground, joints, drivers, loads, g, doc.get("analysis", {}))


# ------------------------------------------------------------------------- state

class State:
    """Poses r (n, 3), R (n, 3, 3) of the moving bodies; velocities v, w and accelerations a, al
    (n, 3): origin velocity/acceleration and angular velocity/acceleration, global."""

    def __init__(self, r, R):
        self.r, self.R = r, R
        n = len(r)
        self.v = self.w = self.a = self.al = np.zeros((n, 3))
        self.moving = False                  # rates not set (zero): positions only

    # the ground is index -1: fixed, identity
    def pose(self, i):
        return (np.zeros(3), np.eye(3)) if i < 0 else (self.r[i], self.R[i])

    def rates(self, i):
        z = np.zeros(3)
        return (z, z, z, z) if i < 0 else (self.v[i], self.w[i], self.a[i], self.al[i])

    def point(self, i, s):
        """Global position, velocity, acceleration of body i's point s (body frame)."""
        r, R = self.pose(i)
        rs = R @ s
        if not self.moving:
            return r + rs, ZERO, ZERO
        v, w, a, al = self.rates(i)
        return (r + rs, v + cross(w, rs),
                a + cross(al, rs) + cross(w, cross(w, rs)))

    def direction(self, i, d):
        """Global direction, its rate and second rate, of body i's vector d (body frame)."""
        _, R = self.pose(i)
        e = R @ d
        if not self.moving:
            return e, ZERO, ZERO
        _, w, _, al = self.rates(i)
        return e, cross(w, e), cross(al, e) + cross(w, cross(w, e))


# ------------------------------------------------------------------------- constraints

class Rows:
    """Constraint rows being assembled: value Phi, Jacobian J (m, 6n), bias gamma (the part of
    Phi'' free of accelerations) and the driver right-hand sides nu (J xdot), eta
    (J xddot + gamma)."""

    def __init__(self, n):
        self.n, self.phi, self.J, self.gamma, self.nu, self.eta = n, [], [], [], [], []

    def add(self, phi, parts, gamma, nu=0.0, eta=0.0):
        row = np.zeros(6 * self.n)
        for i, lin, ang in parts:                      # d Phi = lin . dr_i + ang . dtheta_i
            if i >= 0:
                row[6 * i:6 * i + 3] += lin
                row[6 * i + 3:6 * i + 6] += ang
        self.phi.append(phi), self.J.append(row), self.gamma.append(gamma)
        self.nu.append(nu), self.eta.append(eta)


def coincide(rows, s, j):
    """r_Bq - r_Ap = 0: three rows, along the global axes e."""
    P, Pd, Pdd = s.point(j.a, j.p)
    Q, Qd, Qdd = s.point(j.b, j.q)
    sa, sb = s.pose(j.a)[1] @ j.p, s.pose(j.b)[1] @ j.q
    # d(Q - P) = dr_B + dth_B x sb - dr_A - dth_A x sa;  bias: w x (w x s)
    wa, wb = s.rates(j.a)[1], s.rates(j.b)[1]
    bias = cross(wb, cross(wb, sb)) - cross(wa, cross(wa, sa)) if s.moving else ZERO
    for e in np.eye(3):
        rows.add((Q - P) @ e, [(j.b, e, cross(sb, e)), (j.a, -e, -cross(sa, e))], bias @ e)


def dot_bodies(rows, s, i, d1, k, d2):
    """(R_i d1) . (R_k d2) = 0: two body-fixed directions held perpendicular."""
    e1, e1d, e1b = s.direction(i, d1)
    e2, e2d, e2b = s.direction(k, d2)
    # d(e1.e2) = dth_i . (e1 x e2) + dth_k . (e2 x e1);  Phi'' = e1''.e2 + 2 e1'.e2' + e1.e2''
    rows.add(e1 @ e2, [(i, 0.0, cross(e1, e2)), (k, 0.0, cross(e2, e1))],
             e1b @ e2 + 2 * e1d @ e2d + e1 @ e2b)


def on_line(rows, s, j, n, value=None):
    """(r_Bq - r_Ap) . N = 0 (or = value(t) for a prismatic driver), N = R_A n fixed in A."""
    P, Pd, Pdd = s.point(j.a, j.p)
    Q, Qd, Qdd = s.point(j.b, j.q)
    N, Nd, Nb = s.direction(j.a, n)
    sa, sb = s.pose(j.a)[1] @ j.p, s.pose(j.b)[1] @ j.q
    d, dd = Q - P, Qd - Pd
    wa, wb = s.rates(j.a)[1], s.rates(j.b)[1]
    dbias = cross(wb, cross(wb, sb)) - cross(wa, cross(wa, sa)) if s.moving else ZERO
    # Phi'' = d''.N + 2 d'.N' + d.N''   (d'' and N'' without accelerations in the bias)
    gamma = dbias @ N + 2 * dd @ Nd + d @ Nb
    parts = [(j.b, N, cross(sb, N)), (j.a, -N, -cross(sa, N) + cross(N, d))]
    if value is None:
        rows.add(d @ N, parts, gamma)
    else:
        q, qd, qdd = value
        rows.add(d @ N - q, parts, gamma, qd, qdd)


def relative_angle(s, j, frames):
    """Rotation of B relative to A about the axis, wrapped to (-pi, pi], and the axis E (global)."""
    u = frames["u"]
    E = s.pose(j.a)[1] @ j.axis
    U = s.pose(j.a)[1] @ u
    V = s.pose(j.b)[1] @ frames["u_b"]                  # the B-fixed copy of u at the design pose
    V = V - (V @ E) * E
    return signed_angle(U, V / np.linalg.norm(V), E), E


def joint_frames(model):
    """Per joint: perpendicular axes in A's frame and their B-frame copies at the design pose."""
    out = []
    for j in model.joints:
        RA = np.eye(3) if j.a < 0 else model.bodies[j.a].R0
        RB = np.eye(3) if j.b < 0 else model.bodies[j.b].R0
        RAB0 = RA.T @ RB                                # B's frame in A's at the design pose
        f = {"RAB0": RAB0}
        if j.axis is not None:
            u, w = perpendiculars(j.axis)
            f.update(u=u, w=w, a_b=RAB0.T @ j.axis, u_b=RAB0.T @ u, w_b=RAB0.T @ w)
        out.append(f)
    return out


def constraint_rows(model, frames, s, t_values=None, unwrap=None):
    """Every joint's rows, then every driver's. t_values: per driver (q, qd, qdd) at this sample."""
    rows = Rows(len(model.bodies))
    for j, f in zip(model.joints, frames):
        if j.kind in ("revolute", "universal", "spherical"):
            coincide(rows, s, j)
        if j.kind in ("revolute", "cylindrical"):
            dot_bodies(rows, s, j.a, f["u"], j.b, f["a_b"])
            dot_bodies(rows, s, j.a, f["w"], j.b, f["a_b"])
        if j.kind in ("prismatic", "cylindrical"):
            on_line(rows, s, j, f["u"])
            on_line(rows, s, j, f["w"])
        if j.kind == "prismatic":                       # orientation held: three perpendicularities
            dot_bodies(rows, s, j.a, j.axis, j.b, f["u_b"])
            dot_bodies(rows, s, j.a, f["u"], j.b, f["w_b"])
            dot_bodies(rows, s, j.a, f["w"], j.b, f["a_b"])
        if j.kind == "universal":
            dot_bodies(rows, s, j.a, j.axis, j.b, j.axis2)
    for k, d in enumerate(model.drivers):
        j, f = model.joints[d.joint], frames[d.joint]
        q, qd, qdd = t_values[k]
        if j.kind == "prismatic":
            on_line(rows, s, j, j.axis, (q, qd, qdd))
        else:
            # revolute: q(x) - q(t); q' = (w_B - w_A).E,
            # q'' = (al_B - al_A).E + (w_B - w_A).(w_A x E)
            ang, E = relative_angle(s, j, f)
            ang += 2 * math.pi * round((unwrap[k] - ang) / (2 * math.pi))
            wa, wb = s.rates(j.a)[1], s.rates(j.b)[1]
            rows.add(ang - q, [(j.b, 0.0, E), (j.a, 0.0, -E)], (wb - wa) @ cross(wa, E), qd, qdd)
    return (np.array(rows.phi), np.array(rows.J), np.array(rows.gamma), np.array(rows.nu),
            np.array(rows.eta))


# ------------------------------------------------------------------------- kinematics

def lstsq(A, b, rcond=1e-10):
    """Minimum-norm least-squares solution, singular values below rcond * max dropped."""
    return np.linalg.lstsq(A, b, rcond=rcond)[0]


def step(s, dx):
    """Apply increments dx (6n): r += dr, R = exp(dtheta) R."""
    n = len(s.r)
    d = dx.reshape(n, 6)
    return State(s.r + d[:, :3], np.array([rotvec_matrix(d[i, 3:]) @ s.R[i] for i in range(n)]))


def newton(model, frames, s, targets, unwrap, tol=1e-12, iters=60):
    """Close every constraint from pose s by minimum-norm Newton steps (converged when a step is
    below tol, m or rad: the error left is of the order of its square)."""
    for _ in range(iters):
        phi, J, *_ = constraint_rows(model, frames, s, targets, unwrap)
        dx = lstsq(J, -phi)
        s = step(s, dx)
        if np.max(np.abs(dx)) < tol:
            return s
    phi, *_ = constraint_rows(model, frames, s, targets, unwrap)
    raise RuntimeError(f"no closure: residual {np.max(np.abs(phi)):.3g}")


def driver_values(model, t):
    """Per driver (q, qd, qdd) arrays over t."""
    return [d.motion(np.asarray(t, float)) for d in model.drivers]


def design_state(model):
    return State(np.array([b.r0 for b in model.bodies]), np.array([b.R0 for b in model.bodies]))


def solve_positions(model, t):
    """Poses, rates and accelerations at every sample: Newton from the design pose (its driver
    values ramped to those at t[0]), then continuation sample to sample, each guess predicted by
    the previous sample's rates. Returns the list of States, the joint frames and the drivers'
    values."""
    frames = joint_frames(model)
    s = design_state(model)
    dv = driver_values(model, t)
    # the design pose's driver values (revolute 0, prismatic (r_Bq - r_Ap).e)
    start = []
    for d in model.drivers:
        j = model.joints[d.joint]
        if j.kind == "prismatic":
            P, Q = s.point(j.a, j.p)[0], s.point(j.b, j.q)[0]
            start.append((Q - P) @ (s.pose(j.a)[1] @ j.axis))
        else:
            start.append(0.0)
    gap = max([abs(v[0][0] - a) for a, v in zip(start, dv)], default=0.0)
    for lam in np.linspace(0.0, 1.0, 11)[1:] if gap > 1e-9 else [1.0]:
        tg = [(a + lam * (v[0][0] - a), 0.0, 0.0) for a, v in zip(start, dv)]
        s = newton(model, frames, s, tg, [x[0] for x in tg])
    states = []
    for k in range(len(t)):
        tg = [(v[0][k], v[1][k], v[2][k]) for v in dv]
        if k:                                   # predictor: x + xd h + xdd h^2 / 2
            h = t[k] - t[k - 1]
            prev = states[-1]
            s = step(prev, (np.hstack([prev.v, prev.w]) * h
                            + np.hstack([prev.a, prev.al]) * h * h / 2).ravel())
        s = solve_rates(model, frames, newton(model, frames, s, tg, [x[0] for x in tg]), tg)
        states.append(s)
    return states, frames, dv


def solve_rates(model, frames, s, tg):
    """Velocities and accelerations at one pose (exact; minimum-norm, consistent rows)."""
    unwrap = [x[0] for x in tg]
    phi, J, gamma, nu, eta = constraint_rows(model, frames, s, tg, unwrap)
    xd = lstsq(J, nu)
    n = len(s.r)
    s.v, s.w = xd.reshape(n, 6)[:, :3], xd.reshape(n, 6)[:, 3:]
    s.moving = True
    _, J, gamma, nu, eta = constraint_rows(model, frames, s, tg, unwrap)
    xdd = lstsq(J, eta - gamma)
    s.a, s.al = xdd.reshape(n, 6)[:, :3], xdd.reshape(n, 6)[:, 3:]
    return s


# ------------------------------------------------------------------------- dynamics

def reaction_basis(s, j):
    """Orthonormal basis (6, k) of joint j's constraint space, wrench [F, M] global."""
    E = s.pose(j.a)[1] @ j.axis if j.axis is not None else None
    I3, Z = np.eye(3), np.zeros((3, 3))
    perp = lambda: np.linalg.svd(np.eye(3) - np.outer(E, E))[0][:, :2]   # 2 unit vectors _|_ E
    if j.kind == "spherical":
        return np.vstack([I3, Z])
    if j.kind == "revolute":
        return np.block([[I3, np.zeros((3, 2))], [Z, perp()]])
    if j.kind == "prismatic":
        return np.block([[perp(), Z], [np.zeros((3, 2)), I3]])
    if j.kind == "cylindrical":
        P = perp()
        return np.block([[P, np.zeros((3, 2))], [np.zeros((3, 2)), P]])
    if j.kind == "universal":
        c = cross(E, s.pose(j.b)[1] @ j.axis2)
        return np.block([[I3, np.zeros((3, 1))],
                         [np.zeros((3, 3)), (c / np.linalg.norm(c))[:, None]]])
    raise ValueError(j.kind)


def wrench_columns(s, model, j, W):
    """Generalized forces (6n, k) of wrenches W (6, k) applied by A on B at B's point q:
    on B [F; M + (Q - c_B) x F], on A minus that about A's mass centre."""
    n = len(model.bodies)
    out = np.zeros((6 * n, W.shape[1]))
    Q = s.point(j.b, j.q)[0]
    for i, sign in ((j.b, 1.0), (j.a, -1.0)):
        if i < 0:
            continue
        c = s.r[i] + s.R[i] @ model.bodies[i].com
        F, M = W[:3], W[3:]
        out[6 * i:6 * i + 3] += sign * F
        out[6 * i + 3:6 * i + 6] += sign * (M + skew(Q - c) @ F)
    return out


def applied_and_inertial(model, s):
    """Per body [m a_c - m g - F_ext; I al + w x I w - M_ext about c] (6n,): what the joints
    must supply. Also the kinetic energy, the potential energy (gravity -m g . c, springs
    k (L - L0)^2 / 2; J) and the loads' and gravity's power (W)."""
    n = len(model.bodies)
    b = np.zeros(6 * n)
    ke = 0.0
    pe = sum(-body.mass * model.gravity @ s.point(i, body.com)[0]
             for i, body in enumerate(model.bodies))
    for i, body in enumerate(model.bodies):
        c, cd, cdd = s.point(i, body.com)
        Ig = s.R[i] @ body.inertia @ s.R[i].T
        w, al = s.w[i], s.al[i]
        b[6 * i:6 * i + 3] = body.mass * (cdd - model.gravity)
        b[6 * i + 3:6 * i + 6] = Ig @ al + cross(w, Ig @ w)
        ke += 0.5 * body.mass * cd @ cd + 0.5 * w @ Ig @ w
    power = sum(body.mass * model.gravity @ s.point(i, body.com)[1]
                for i, body in enumerate(model.bodies))
    for ld in model.loads:
        if ld["kind"] == "spring":
            L = np.linalg.norm(s.point(ld["b2"], ld["s2"])[0] - s.point(ld["b"], ld["s"])[0])
            pe += 0.5 * ld["k"] * (L - ld["l0"]) ** 2
        for i, F, P, M in load_wrenches(ld, s):
            if i < 0:
                continue
            c = s.r[i] + s.R[i] @ model.bodies[i].com
            b[6 * i:6 * i + 3] -= F
            b[6 * i + 3:6 * i + 6] -= M + cross(P - c, F)
            v = s.v[i] + cross(s.w[i], P - s.r[i])     # velocity of the body's point at P
            power += F @ v + M @ s.w[i]
    return b, ke, pe, power


def load_wrenches(ld, s):
    """(body, force, point, couple) of one load, global, SI."""
    z = np.zeros(3)
    if ld["kind"] == "force":
        P = s.point(ld["b"], ld["s"])[0]
        return [(ld["b"], ld["value"], P, z)]
    if ld["kind"] == "torque":
        return [(ld["b"], z, s.pose(ld["b"])[0], ld["value"])]
    P1, P2 = s.point(ld["b"], ld["s"])[0], s.point(ld["b2"], ld["s2"])[0]
    d = P2 - P1
    L = np.linalg.norm(d)
    T = ld["k"] * (L - ld["l0"])                      # tension pulls the ends together
    return [(ld["b"], T * d / L, P1, z), (ld["b2"], -T * d / L, P2, z)]


def effort_columns(model, s):
    """Generalized forces (6n, m) of unit driver efforts: revolute a couple +E on B (-E on A),
    prismatic a force +E at B's point q on B (-E there on A)."""
    cols = []
    for d in model.drivers:
        j = model.joints[d.joint]
        E = s.pose(j.a)[1] @ j.axis
        W = np.concatenate([np.zeros(3), E] if j.kind == "revolute" else [E, np.zeros(3)])
        cols.append(wrench_columns(s, model, j, W[:, None]))
    return np.hstack(cols) if cols else np.zeros((6 * len(model.bodies), 0))


def solve_dynamics(model, frames, s):
    """Efforts (m,) and reactions (n_joints, 6) [F, M about q] by the minimum-norm solve."""
    bases = [reaction_basis(s, j) for j in model.joints]
    A_lam = np.hstack([wrench_columns(s, model, j, B) for j, B in zip(model.joints, bases)])
    A_tau = effort_columns(model, s)
    b, ke, pe, power = applied_and_inertial(model, s)
    # min |lam| s.t. A_lam lam + A_tau tau = b: project the efforts' range out, then tau
    P = np.eye(len(b)) - A_tau @ np.linalg.pinv(A_tau)
    lam = lstsq(P @ A_lam, P @ b, rcond=1e-9)
    tau = np.linalg.lstsq(A_tau, b - A_lam @ lam, rcond=None)[0] if A_tau.size else np.zeros(0)
    resid = np.max(np.abs(A_lam @ lam + A_tau @ tau - b)) if len(b) else 0.0
    out, k = [], 0
    for B in bases:
        out.append(B @ lam[k:k + B.shape[1]])
        k += B.shape[1]
    return tau, np.array(out), ke, pe, power, resid


def undetermined_basis(model, t):
    """Per sample, an orthonormal basis (6 n_joints, k) of the reaction sets that rigid-body
    statics leaves free: stacked [F, M] of every joint (model order) with every body's equations
    satisfied under no load and no effort (the null space of the projected system)."""
    states, frames, dv = solve_positions(model, np.asarray(t, float))
    out = []
    for s in states:
        bases = [reaction_basis(s, j) for j in model.joints]
        A_lam = np.hstack([wrench_columns(s, model, j, B) for j, B in zip(model.joints, bases)])
        A_tau = effort_columns(model, s)
        P = np.eye(len(A_lam)) - A_tau @ np.linalg.pinv(A_tau)
        _, sv, Vt = np.linalg.svd(P @ A_lam)
        rank = int(np.sum(sv > 1e-9 * sv[0]))
        stacked = np.zeros((6 * len(bases), A_lam.shape[1]))   # joint bases, block diagonal
        k = 0
        for i, B in enumerate(bases):
            stacked[6 * i:6 * i + 6, k:k + B.shape[1]] = B
            k += B.shape[1]
        out.append(stacked @ Vt[rank:].T)
    return out


# ------------------------------------------------------------------------- columns

def joint_coordinates(model, frames, s, prev):
    """{column: value} of q_, qd_, qdd_ at one sample (angles near prev's for continuity)."""
    out = {}
    for j, f in zip(model.joints, frames):
        RA, RB = s.pose(j.a)[1], s.pose(j.b)[1]
        wa, wb, ala, alb = s.rates(j.a)[1], s.rates(j.b)[1], s.rates(j.a)[3], s.rates(j.b)[3]
        wr, alr = wb - wa, alb - ala

        def rot(E, q_name, ang, Ed):
            # q' = (w_B - w_A).E, q'' = (al_B - al_A).E + (w_B - w_A).E'
            if "q_" + q_name in prev:
                ang += 2 * math.pi * round((prev["q_" + q_name] - ang) / (2 * math.pi))
            out["q_" + q_name] = ang
            out["qd_" + q_name], out["qdd_" + q_name] = wr @ E, alr @ E + wr @ Ed

        def slide(q_name):
            P, Pd, Pdd = s.point(j.a, j.p)
            Q, Qd, Qdd = s.point(j.b, j.q)
            E, Ed, Edd = s.direction(j.a, j.axis)
            d, dd, ddd = Q - P, Qd - Pd, Qdd - Pdd
            out["q_" + q_name] = d @ E
            out["qd_" + q_name] = dd @ E + d @ Ed
            out["qdd_" + q_name] = ddd @ E + 2 * dd @ Ed + d @ Edd

        if j.kind == "revolute":
            ang, E = relative_angle(s, j, f)
            rot(E, j.name, ang, cross(wa, E))
        elif j.kind == "prismatic":
            slide(j.name)
        elif j.kind == "cylindrical":
            slide(j.name + ".s")
            ang, E = relative_angle(s, j, f)
            rot(E, j.name + ".r", ang, cross(wa, E))
        elif j.kind == "universal":
            # R_A^T R_B = Rot(a1, q1) RAB0 Rot(a2, q2)
            a1, a2, RAB0 = j.axis, j.axis2, f["RAB0"]
            RAB = RA.T @ RB
            c2 = RAB0 @ a2
            q1 = signed_angle(c2, RAB @ a2, a1)
            M = RAB0.T @ rotvec_matrix(-q1 * a1) @ RAB
            x = RAB0.T @ a1
            q2 = signed_angle(x, M @ x, a2)
            E1, E2 = RA @ a1, RB @ a2
            rot(E1, j.name + ".1", q1, cross(wa, E1))
            rot(E2, j.name + ".2", q2, cross(wb, E2))
    return out


def analyze(model, t):
    """Every contract column over times t (s): dict name -> (T,) array."""
    t = np.asarray(t, float)
    states, frames, dv = solve_positions(model, t)
    cols: dict[str, list] = {"t": list(t)}
    put = lambda k, v: cols.setdefault(k, []).append(float(v))
    prev, quat_prev = {}, [None] * len(model.bodies)
    for k, s in enumerate(states):
        tg = [(v[0][k], v[1][k], v[2][k]) for v in dv]
        prev = joint_coordinates(model, frames, s, prev)
        for name, v in prev.items():
            put(name, v)
        for i, body in enumerate(model.bodies):
            qt = quaternion(s.R[i])
            ref = quat_prev[i]
            if (ref is None and qt[0] < 0) or (ref is not None and qt @ ref < 0):
                qt = -qt
            quat_prev[i] = qt
            for c, v in zip("wxyz", qt):
                put(f"quat_{c}_{body.name}", v)
            for c, v in zip("xyz", s.w[i]):
                put(f"omega_{c}_{body.name}", v)
            for c, v in zip("xyz", s.al[i]):
                put(f"alpha_{c}_{body.name}", v)
            for pn, pt in body.points.items():
                P, V, A = s.point(i, pt)
                for c in range(3):
                    put(f"{'xyz'[c]}_{body.name}.{pn}", P[c])
                    put(f"v{'xyz'[c]}_{body.name}.{pn}", V[c])
                    put(f"a{'xyz'[c]}_{body.name}.{pn}", A[c])
        tau, react, ke, pe, power, resid = solve_dynamics(model, frames, s)
        for d, e in zip(model.drivers, tau):
            j = model.joints[d.joint]
            put(("tau_" if j.kind == "revolute" else "force_") + j.name, e)
        for j, w in zip(model.joints, react):
            for c, v in zip(("Fx", "Fy", "Fz", "Mx", "My", "Mz"), w):
                if c[0] == "M" and j.kind == "spherical":
                    continue
                put(f"{c}_{j.name}", v)
        # conditioning: the constraint Jacobian's (driver rows included) rank and its smallest
        # kept singular value over its largest
        _, J, *_ = constraint_rows(model, frames, s, tg, [x[0] for x in tg])
        sv = np.linalg.svd(J, compute_uv=False)
        kept = sv[sv > 1e-9 * sv[0]]
        put("jacobian_rank", len(kept))
        put("jacobian_conditioning", kept[-1] / sv[0])
        put("kinetic_energy", ke)
        put("potential_energy", pe)
        put("load_power", power)
        put("ne_residual", resid)
    return {k: np.array(v) for k, v in cols.items()}


def run(path, t):
    """The reference's columns of the model file at path over times t."""
    return analyze(load(path), t)
