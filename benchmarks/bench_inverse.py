"""Hoeken's full inverse dynamics, linkdyn beside code written for this one four-bar (issue 28).

Every implementation computes, per sample, the 18 numbers of the inverse dynamics: the angle,
angular velocity and angular acceleration of the crank, the coupler and the rocker, the driving
torque and the force of each of the four pins (x, y). Measured in one run, on one core, each as
a ratio to a scalar C kernel written by hand for this four-bar (its time per sample divided by
the other's; larger is faster):

- C, scalar: the kernel below compiled at run time by the system ``cc`` with
  ``-O2 -fno-tree-vectorize`` and called through ctypes;
- C, vectorized: the same source with ``-O3 -march=native -ffast-math -DSPLIT_SINCOS``, if it
  builds: fast-math lets gcc call glibc's vector ``cos`` and ``atan2`` (libmvec); the macro
  takes the crank's sine as a cosine, since gcc fuses a sine and a cosine of one angle into a
  ``sincos`` that it does not vectorize (the scalar build keeps ``sin``);
- numpy written by hand for this four-bar, on chunks of 8192 samples;
- sympy.physics.mechanics: the loop closure's rates and the three links' Newton-Euler equations
  derived and solved symbolically, lambdified to numpy, on chunks of 8192 samples (needs sympy:
  ``pip install 'linkdyn[bench]'``);
- linkdyn's compiled backend (``linkdyn.analyze(model, t, backend="compiled")``), its numpy
  backend, and a batch of 2,000 designs x 360 samples (ground pin and coupler length varied,
  one stacked layout, ``analysis.analyze_layout``).

Every baseline writes fresh outputs (as linkdyn does) and is checked against linkdyn's numpy
backend before it is timed. linkdyn's compiled time is then split by stage: each kernel alone
on outputs already touched (as ``bench_kernels.py`` runs them; the dynamics kernel takes the
reactions in its blocks), one ``analyze`` call stage by stage as it runs (the layout, the
assembly and continuation nodes, the kinematics kernel's call, the loads, the dynamics and
reactions, the finiteness checks, the rest), and the kinematics and dynamics kernels step by
step.

Without a C compiler the C kernels are skipped (said so) and the ratios are to hand-written
numpy.

Usage: python benchmarks/bench_inverse.py [--samples N] [--repeat R] [--clock cpu|wall]
                                          [--designs D]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import ctypes  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn import analysis  # noqa: E402

from bench_ceiling import numbers  # noqa: E402
from bench_hoeken import one_core  # noqa: E402
from ratio import best_time, options, verdict  # noqa: E402

ROWS = 18          # phi, omega, alpha of crank, coupler, rocker; tau; Fx, Fy of J1..J4
CHUNK = 8192       # samples per pass of the numpy baselines
TARGET_SINGLE = 1.0   # linkdyn compiled, one mechanism, against scalar C (issue 28)
TARGET_BATCH = 0.8    # 2,000 designs x 360 samples in one batch
SCALAR_FLAGS = ["-O2", "-fno-tree-vectorize"]
VECTOR_FLAGS = ["-O3", "-march=native", "-ffast-math", "-DSPLIT_SINCOS"]
BOX = {"bodies.ground.points.O4[0]": (80.0, 100.0), "bodies.coupler.points.O3[0]": (105.0, 125.0)}

# Parameters p[]: u (2), v (2), pa (2), pb (2), side, then per moving link mass, inertia about
# its origin, mass centre (x, y) in its frame. Outputs out[m * T + k], rows as ROWS above.
C_SOURCE = r"""
#include <math.h>

void hoeken(long T, const double *restrict t, double w, const double *restrict p,
            double *restrict out)
{
    const double u0 = p[0], u1 = p[1], pax = p[4], pay = p[5], side = p[8];
    const double b = sqrt(p[2] * p[2] + p[3] * p[3]), c = sqrt(p[6] * p[6] + p[7] * p[7]);
    const double phv = atan2(p[3], p[2]), phb = atan2(p[7], p[6]);
    const double vx = p[2] / b, vy = p[3] / b, bx = p[6] / c, by = p[7] / c;
    const double m1 = p[9], i1 = p[10], g1x = p[11], g1y = p[12];
    const double m2 = p[13], i2 = p[14], g2x = p[15], g2y = p[16];
    const double m3 = p[17], i3 = p[18], g3x = p[19], g3y = p[20];
#pragma GCC ivdep   /* the 18 rows of out do not overlap */
    for (long k = 0; k < T; k++) {
        /* crank at w t; its pin R2 = R(phi1) u */
        double p1 = w * t[k], c1 = cos(p1);
#ifdef SPLIT_SINCOS
        double s1 = cos(p1 - M_PI_2);   /* not fused into sincos, which gcc does not vectorize */
#else
        double s1 = sin(p1);
#endif
        double r2x = c1 * u0 - s1 * u1, r2y = s1 * u0 + c1 * u1;
        /* rocker pin R3: |R3 - R2| = b, |pa - R3| = c (circle intersection) */
        double dx = pax - r2x, dy = pay - r2y, d = sqrt(dx * dx + dy * dy);
        double kk = (b * b - c * c + d * d) / (2 * d), h = sqrt(b * b - kk * kk);
        double r3x = r2x + (kk * dx - side * h * dy) / d, r3y = r2y + (kk * dy + side * h * dx) / d;
        double e2x = r3x - r2x, e2y = r3y - r2y, e3x = pax - r3x, e3y = pay - r3y;
        double p2 = atan2(e2y, e2x) - phv, p3 = atan2(e3y, e3x) - phb;
        double c2 = (e2x * vx + e2y * vy) / b, s2 = (e2y * vx - e2x * vy) / b;
        double c3 = (e3x * bx + e3y * by) / c, s3 = (e3y * bx - e3x * by) / c;
        /* rates: w2 perp(e2) + w3 perp(e3) = -w perp(R2) */
        double det = e2x * e3y - e2y * e3x;
        double w2 = w * (r2y * e3x - r2x * e3y) / det, w3 = w * (r2x * e2y - r2y * e2x) / det;
        /* accelerations: al2 perp(e2) + al3 perp(e3) = w^2 R2 + w2^2 e2 + w3^2 e3 */
        double fx = w * w * r2x + w2 * w2 * e2x + w3 * w3 * e3x;
        double fy = w * w * r2y + w2 * w2 * e2y + w3 * w3 * e3y;
        double al2 = (fx * e3x + fy * e3y) / det, al3 = -(fx * e2x + fy * e2y) / det;
        double a2x = -w * w * r2x, a2y = -w * w * r2y;
        double a3x = a2x - al2 * e2y - w2 * w2 * e2x, a3y = a2y + al2 * e2x - w2 * w2 * e2y;
        /* Newton-Euler about each origin, d = R(phi) g: F = m (a + al perp(d) - w^2 d),
           N = I_O al + m d x a */
        double d1x = c1 * g1x - s1 * g1y, d1y = s1 * g1x + c1 * g1y;
        double d2x = c2 * g2x - s2 * g2y, d2y = s2 * g2x + c2 * g2y;
        double d3x = c3 * g3x - s3 * g3y, d3y = s3 * g3x + c3 * g3y;
        double f1x = -m1 * w * w * d1x, f1y = -m1 * w * w * d1y;
        double f2x = m2 * (a2x - al2 * d2y - w2 * w2 * d2x), f2y = m2 * (a2y + al2 * d2x - w2 * w2 * d2y);
        double n2 = i2 * al2 + m2 * (d2x * a2y - d2y * a2x);
        double f3x = m3 * (a3x - al3 * d3y - w3 * w3 * d3x), f3y = m3 * (a3y + al3 * d3x - w3 * w3 * d3y);
        double n3 = i3 * al3 + m3 * (d3x * a3y - d3y * a3x);
        /* pins: e2 x F3 = -N2, e3 x F3 = e3 x F_rocker - N3; then each link's balance */
        double mm1 = -n2, mm2 = e3x * f3y - e3y * f3x - n3;
        double j3x = (mm1 * e3x - e2x * mm2) / det, j3y = (mm1 * e3y - e2y * mm2) / det;
        double j4x = f3x - j3x, j4y = f3y - j3y, j2x = f2x + j3x, j2y = f2y + j3y;
        double j1x = f1x + j2x, j1y = f1y + j2y;
        double tau = r2x * j2y - r2y * j2x;   /* the crank turns at constant speed: I_O al = 0 */
        out[k] = p1; out[T + k] = w; out[2 * T + k] = 0.0;
        out[3 * T + k] = p2; out[4 * T + k] = w2; out[5 * T + k] = al2;
        out[6 * T + k] = p3; out[7 * T + k] = w3; out[8 * T + k] = al3;
        out[9 * T + k] = tau;
        out[10 * T + k] = j1x; out[11 * T + k] = j1y; out[12 * T + k] = j2x; out[13 * T + k] = j2y;
        out[14 * T + k] = j3x; out[15 * T + k] = j3y; out[16 * T + k] = j4x; out[17 * T + k] = j4y;
        (void)i1;
    }
}
"""


def parameters(p: dict) -> np.ndarray:
    """The C kernel's ``p[]`` from :func:`bench_ceiling.numbers`."""
    links = [[p["mass"][i], p["i_o"][i], *p["com"][i]] for i in (1, 2, 3)]
    return np.array([*p["u"], *p["v"], *p["pa"], *p["pb"], p["side"], *sum(links, [])], float)


def c_kernel(flags: list[str], workdir: Path):
    """The C kernel built with ``flags``: ``run(t, out)`` fills ``out`` (18, T); None (and
    the compiler's complaint printed) when it does not build."""
    src = workdir / "hoeken.c"
    src.write_text(C_SOURCE)
    lib = workdir / f"hoeken{len(list(workdir.glob('*.so')))}.so"
    done = subprocess.run(["cc", *flags, "-shared", "-fPIC", str(src), "-o", str(lib), "-lm"],
                          capture_output=True, text=True)
    if done.returncode != 0:
        print(f"  (cc {' '.join(flags)} does not build it: {done.stderr.strip()[:200]})")
        return None
    fn = ctypes.CDLL(str(lib)).hoeken
    dbl = ctypes.POINTER(ctypes.c_double)
    fn.argtypes = [ctypes.c_long, dbl, ctypes.c_double, dbl, dbl]
    fn.restype = None

    def bind(mech):
        p = numbers(mech)
        w, par = p["w"], parameters(p)

        def run(t, out):
            fn(len(t), t.ctypes.data_as(dbl), w, par.ctypes.data_as(dbl), out.ctypes.data_as(dbl))
            return out
        return run
    return bind


def numpy_kernel(mech):
    """Hoeken's inverse dynamics written by hand in numpy: ``run(t, out)``, chunks of 8192."""
    p = numbers(mech)
    w, (u0, u1), (pax, pay), side = p["w"], p["u"], p["pa"], p["side"]
    b, c = np.hypot(*p["v"]), np.hypot(*p["pb"])
    phv, phb = np.arctan2(p["v"][1], p["v"][0]), np.arctan2(p["pb"][1], p["pb"][0])
    (m1, m2, m3), (i2, i3) = p["mass"][1:], p["i_o"][2:]
    (g1x, g1y), (g2x, g2y), (g3x, g3y) = p["com"][1:]

    def chunk(t):
        p1 = w * t
        c1, s1 = np.cos(p1), np.sin(p1)
        r2x, r2y = c1 * u0 - s1 * u1, s1 * u0 + c1 * u1
        dx, dy = pax - r2x, pay - r2y
        d = np.sqrt(dx * dx + dy * dy)
        kk = (b * b - c * c + d * d) / (2 * d)
        h = np.sqrt(b * b - kk * kk)
        e2x, e2y = (kk * dx - side * h * dy) / d, (kk * dy + side * h * dx) / d
        e3x, e3y = dx - e2x, dy - e2y
        p2, p3 = np.arctan2(e2y, e2x) - phv, np.arctan2(e3y, e3x) - phb
        c2, s2, c3, s3 = np.cos(p2), np.sin(p2), np.cos(p3), np.sin(p3)
        det = e2x * e3y - e2y * e3x
        w2, w3 = w * (r2y * e3x - r2x * e3y) / det, w * (r2x * e2y - r2y * e2x) / det
        fx = w * w * r2x + w2 * w2 * e2x + w3 * w3 * e3x
        fy = w * w * r2y + w2 * w2 * e2y + w3 * w3 * e3y
        al2, al3 = (fx * e3x + fy * e3y) / det, -(fx * e2x + fy * e2y) / det
        a2x, a2y = -w * w * r2x, -w * w * r2y
        a3x, a3y = a2x - al2 * e2y - w2 * w2 * e2x, a2y + al2 * e2x - w2 * w2 * e2y
        d1x, d1y = c1 * g1x - s1 * g1y, s1 * g1x + c1 * g1y
        d2x, d2y = c2 * g2x - s2 * g2y, s2 * g2x + c2 * g2y
        d3x, d3y = c3 * g3x - s3 * g3y, s3 * g3x + c3 * g3y
        f2x, f2y = m2 * (a2x - al2 * d2y - w2 * w2 * d2x), m2 * (a2y + al2 * d2x - w2 * w2 * d2y)
        f3x, f3y = m3 * (a3x - al3 * d3y - w3 * w3 * d3x), m3 * (a3y + al3 * d3x - w3 * w3 * d3y)
        n2 = i2 * al2 + m2 * (d2x * a2y - d2y * a2x)
        n3 = i3 * al3 + m3 * (d3x * a3y - d3y * a3x)
        mm2 = e3x * f3y - e3y * f3x - n3
        j3x, j3y = (-n2 * e3x - e2x * mm2) / det, (-n2 * e3y - e2y * mm2) / det
        j2x, j2y = f2x + j3x, f2y + j3y
        return (p1, w, 0.0, p2, w2, al2, p3, w3, al3, r2x * j2y - r2y * j2x,
                j2x - m1 * w * w * d1x, j2y - m1 * w * w * d1y, j2x, j2y, j3x, j3y,
                f3x - j3x, f3y - j3y)

    def run(t, out):
        for k in range(0, len(t), CHUNK):
            for m, x in enumerate(chunk(t[k:k + CHUNK])):
                out[m, k:k + CHUNK] = x
        return out
    return run


def sympy_kernel(mech):
    """Hoeken's inverse dynamics from sympy.physics.mechanics: the closure's rates and
    accelerations (its Jacobian solved symbolically) and the 9 Newton-Euler equations of the
    three links solved symbolically for the torque and the pin forces, each lambdified to numpy;
    the positions by the circle intersection written in sympy. ``run(t, out)``, chunks of 8192.
    None without sympy."""
    try:
        import sympy as sm
        from sympy.physics import mechanics as me
    except ImportError:
        return None
    p = numbers(mech)
    w, side = p["w"], p["side"]
    q = me.dynamicsymbols("q1:4")              # absolute angles of crank, coupler, rocker
    N = me.ReferenceFrame("N")
    A, B, C = (N.orientnew(n, "Axis", (x, N.z)) for n, x in zip("ABC", q))
    O1 = me.Point("O1")
    O2 = O1.locatenew("O2", p["u"][0] * A.x + p["u"][1] * A.y)
    O3 = O2.locatenew("O3", p["v"][0] * B.x + p["v"][1] * B.y)
    O4 = O3.locatenew("O4", p["pb"][0] * C.x + p["pb"][1] * C.y)
    G = [o.locatenew(f"G{i}", p["com"][i][0] * F.x + p["com"][i][1] * F.y)
         for i, (o, F) in enumerate(((O1, A), (O2, B), (O3, C)), 1)]
    # loop closure f(q) = O4 - pa = 0 and its two time derivatives
    xy = lambda vec: sm.Matrix([vec.dot(N.x), vec.dot(N.y)])  # noqa: E731
    f = xy(O4.pos_from(O1)) - sm.Matrix(p["pa"])
    t_ = me.dynamicsymbols._t
    Q, U, UD = sm.symbols("Q1:4"), sm.symbols("U1:4"), sm.symbols("UD1:4")
    plain = {**{x.diff(t_, 2): y for x, y in zip(q, UD)}, **{x.diff(t_): y for x, y in zip(q, U)}}
    plain2 = dict(zip(q, Q))

    def sub(e):
        return e.subs(plain).subs(plain2)
    J = sub(f.jacobian(q[1:]))
    rates = J.LUsolve(-sub(f.jacobian(q[:1])) * sm.Matrix([U[0]]))
    acc = J.LUsolve(-sub(f.diff(t_, 2)).subs(dict(zip(UD[1:], (0, 0)))))
    # Newton-Euler of each link about its mass centre, unknowns tau and the pin forces
    F = sm.symbols("F1x F1y F2x F2y F3x F3y F4x F4y")
    tau = sm.Symbol("tau")
    f1, f2, f3, f4 = (sm.Matrix(F[2 * i:2 * i + 2]) for i in range(4))
    pa = sm.Matrix(p["pa"])
    cross = lambda r, v: r[0] * v[1] - r[1] * v[0]  # noqa: E731
    eqs = []
    links = ((1, O1, f1, O2, -f2), (2, O2, f2, O3, -f3), (3, O3, f3, None, f4))
    for (i, o, fa, ob, fb), g, al in zip(links, G, UD):
        rg = sub(xy(g.pos_from(O1)))
        ag = sub(xy(g.pos_from(O1).dt(N).dt(N)))
        rb = pa if ob is None else sub(xy(ob.pos_from(O1)))
        i_g = p["i_o"][i] - p["mass"][i] * float(np.sum(p["com"][i] ** 2))
        eqs += list(fa + fb - p["mass"][i] * ag)
        eqs.append(cross(sub(xy(o.pos_from(O1))) - rg, fa) + cross(rb - rg, fb)
                   + (tau if i == 1 else 0) - i_g * al)
    M, rhs = sm.linear_eq_to_matrix(eqs, [tau, *F])
    forces = M.LUsolve(rhs)
    # positions: the rocker pin by the circle intersection from the crank angle
    b, c = float(np.hypot(*p["v"])), float(np.hypot(*p["pb"]))
    r2 = sub(xy(O2.pos_from(O1)))
    dv = pa - r2
    d = sm.sqrt(dv.dot(dv))
    kk = (b * b - c * c + d * d) / (2 * d)
    h = sm.sqrt(b * b - kk * kk)
    e2 = (kk * dv + side * h * sm.Matrix([-dv[1], dv[0]])) / d
    e3 = dv - e2
    angles = [sm.atan2(e2[1], e2[0]) - np.arctan2(p["v"][1], p["v"][0]),
              sm.atan2(e3[1], e3[0]) - np.arctan2(p["pb"][1], p["pb"][0])]
    f_pos = sm.lambdify([Q[0]], angles, "numpy", cse=True)
    f_rate = sm.lambdify([Q, U[0]], list(rates), "numpy", cse=True)
    f_acc = sm.lambdify([Q, U, UD[0]], list(acc), "numpy", cse=True)
    f_dyn = sm.lambdify([Q, U, UD], list(forces), "numpy", cse=True)

    def run(t, out):
        for k in range(0, len(t), CHUNK):
            q1 = w * t[k:k + CHUNK]
            qq = (q1, *f_pos(q1))
            w2, w3 = f_rate(qq, w)
            uu = (w, w2, w3)
            al2, al3 = f_acc(qq, uu, 0.0)
            rows = (q1, w, 0.0, qq[1], w2, al2, qq[2], w3, al3,
                    *f_dyn(qq, uu, (0.0, al2, al3)))
            for m, x in enumerate(rows):
                out[m, k:k + CHUNK] = x
        return out
    return run


def check(name: str, run, mech, t) -> None:
    """``run``'s 18 rows against linkdyn's numpy backend: angles to 1e-9 rad modulo 2 pi,
    rates and accelerations to 1e-9 of their peak, torque and pin forces to 1e-9 of the peak
    pin force (the torque of its own)."""
    cols = linkdyn.analyze(mech, t, backend="numpy").columns
    keys = [f"{x}_{b}" for b in ("crank", "coupler", "rocker") for x in ("phi", "omega", "alpha")]
    forces = [f"F{x}_J{j}" for j in (1, 2, 3, 4) for x in "xy"]
    keys += ["tau_J1", *forces]
    out = run(t, np.empty((ROWS, len(t))))
    peak_force = max(np.abs(cols[k]).max() for k in forces)
    for m, key in enumerate(keys):
        diff = out[m] - cols[key]
        if key.startswith("phi"):
            diff, scale = (diff + np.pi) % (2 * np.pi) - np.pi, 1.0
        else:
            scale = peak_force if key in forces else max(np.abs(cols[key]).max(), 1e-300)
        err = np.abs(diff).max()
        assert err <= 1e-9 * scale, f"{name}: {key} differs from linkdyn's by {err:.3g}"


def batch(mech, designs: int, samples: int):
    """``solve()``: linkdyn's compiled full analysis of ``designs`` Hoeken designs (ground pin
    and coupler length varied, Sobol) x ``samples`` samples in one stacked layout, built once."""
    from linkdyn.studies import Task, sample, space
    sp = space(linkdyn.example_path("hoeken"), list(BOX))
    task = Task(sp, np.zeros(1), ()).with_builder(*np.array(list(BOX.values())).T)
    layout, guesses = task.builder.stacked(task.builder.numbers(
        sample(list(BOX.values()), "sobol", designs, seed=0)))
    models = task.builder.guess_models(guesses, designs)
    t = np.linspace(0.0, mech.drivers[0].period, samples)

    def solve():
        sol = analysis.analyze_layout(models, layout, t, backend="compiled")
        assert sol.valid.all(), "a design of the batch does not assemble"
        return sol
    return solve


def analyze_stages(mech, t, repeat: int, clock) -> dict:
    """Where one ``linkdyn.analyze(mech, t, backend="compiled")`` spends its time, stage by
    stage, each the least of ``repeat`` calls (seconds): the layout, the assembly and
    continuation nodes (``positions.follow``), the kinematics kernel's call (its inputs and
    outputs allocated), the loads, the dynamics and reactions, the finiteness checks, and the
    rest (the driver values, the ``Solution``, Python between the stages)."""
    from linkdyn import loads
    from linkdyn.dynamics import compiled as dc
    from linkdyn.kinematics import compiled as kc
    from linkdyn.kinematics import solution
    spots = {"layout (compile_layout)": (solution, "compile_layout"),
             "assembly, continuation nodes (follow)": (solution, "follow"),
             "kinematics kernel (kinematics.compiled.run)": (kc, "run"),
             "loads (loads.wrenches)": (loads, "wrenches"),
             "dynamics and reactions (one kernel)": (dc, "inverse"),
             "dynamics (dynamics.compiled.solve)": (dc, "solve"),
             "reactions (dynamics.compiled.reactions)": (dc, "reactions"),
             "finiteness of the outputs (analysis._finite)": (analysis, "_finite")}
    spots = {k: v for k, v in spots.items() if hasattr(*v)}
    real = {k: getattr(*v) for k, v in spots.items()}
    spent = {k: [] for k in spots}

    def spy(name, fn):
        def call(*a, **kw):
            t0 = clock()
            try:
                return fn(*a, **kw)
            finally:
                spent[name][-1] += clock() - t0
        return call
    best = {k: np.inf for k in spots}
    total = np.inf
    for (mod, attr), name in zip(spots.values(), spots):
        setattr(mod, attr, spy(name, real[name]))
    try:
        for _ in range(repeat):
            for k in spent:
                spent[k].append(0.0)
            t0 = clock()
            linkdyn.analyze(mech, t, backend="compiled")
            total = min(total, clock() - t0)
            best = {k: min(best[k], spent[k][-1]) for k in spots}
    finally:
        for (mod, attr), name in zip(spots.values(), spots):
            setattr(mod, attr, real[name])
    out = {k: x for k, x in best.items() if x > 0}
    out["the rest (drivers, Solution, Python)"] = max(total - sum(out.values()), 0.0)
    return out


def dynamics_steps(args):
    """The dynamics kernel's steps (its reactions too, as ``analyze`` runs them in the same
    blocks), each a function of a block ``(k0, nb)`` of design 0 on the arguments of the real
    call, with scratch of their own: ``(table, block)``."""
    from linkdyn.dynamics import compiled as dc
    from linkdyn.compiled import from_python as py   # a kernel's helper, callable from Python
    (L, c, s, r, e, tw, twd, J, w_ext, o_wstar, o_wtilde, o_Q, o_lam, o_tau, o_ke, o_pivot,
     *rest) = args
    block = rest[-2]
    o_on = rest[0] if len(rest) == 3 else np.zeros((0, 3) + c.shape[1:])
    n, m, n_rows, n_drv = len(L.parent), len(L.dependent), o_lam.shape[0], o_tau.shape[0]
    B = block
    w_const, ws, wt = (np.zeros((n, 3, 1, B)) for _ in range(3))
    Q, A, ke, piv = np.zeros((n, 1, B)), np.zeros((m, m + 1, B)), np.zeros(B), np.zeros(B)
    lam = np.zeros((max(m, n_rows, 1), B))
    wc, tree, tau_b, zero = (np.zeros((n, 3, B)), np.zeros((n, 3, 1, B)),
                             np.zeros((max(n_drv, 1), B)), np.zeros(B))
    table = {
        "Newton-Euler w_star": lambda k0, nb: py(dc._newton_euler)(
            L, 0, 0, k0, nb, 0, 0, c, s, tw, twd, w_ext, w_const, ke, ws, wt),
        "composite w_tilde": lambda k0, nb: py(dc._composite)(L, r, 0, k0, nb, 0, 0, wt),
        "generalized forces Q": lambda k0, nb: py(dc._generalized)(L, 0, k0, nb, 0, 0, e, wt, Q),
        "multipliers and efforts": lambda k0, nb: py(dc._multipliers)(
            L, 0, k0, nb, J, Q[:, 0, 0:nb], A, lam, piv, o_lam, o_tau, o_pivot)}
    if o_on.shape[0]:
        table["cut-joint wrenches"] = lambda k0, nb: py(dc._cut_wrenches)(
            L, 0, 0, k0, nb, c, s, r, lam, zero, wc, o_on)
        table["tree reactions"] = lambda k0, nb: py(dc._tree_reactions)(
            L, 0, 0, k0, nb, 0, 0, False, c, s, r, e, tau_b, wc, ws, tree, o_on)
    return table, block


def system_share(fn, samples: int, repeat: int) -> tuple[float, float, int]:
    """The call of ``fn`` with the least CPU time of ``repeat``: its user and system CPU
    seconds per sample and the page faults it took (the system's part is mostly the first
    touch of fresh output memory)."""
    best = None
    for _ in range(repeat):
        r0 = resource.getrusage(resource.RUSAGE_SELF)
        fn()
        r1 = resource.getrusage(resource.RUSAGE_SELF)
        x = ((r1.ru_utime - r0.ru_utime) / samples, (r1.ru_stime - r0.ru_stime) / samples,
             r1.ru_minflt - r0.ru_minflt)
        best = x if best is None or sum(x[:2]) < sum(best[:2]) else best
    return best


def more(ap):
    ap.add_argument("--designs", type=int, default=2000,
                    help="designs of the batch (x 360 samples)")


def main():
    args = options(__doc__, samples=200_000, more=more)
    one_core()
    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    period = mech.drivers[0].period
    T = args.samples
    t = np.linspace(0.0, period, T)
    tc = np.linspace(-0.3, 1.2, 2001) * period   # the check: past a turn either way

    runs = {}
    workdir = Path(tempfile.mkdtemp(prefix="linkdyn-bench-"))
    try:
        if shutil.which("cc") is None:
            print("no C compiler (cc) on the PATH: the C kernels are skipped, "
                  "the ratios are to hand-written numpy")
        else:
            for name, flags in (("C, scalar", SCALAR_FLAGS), ("C, vectorized", VECTOR_FLAGS)):
                bind = c_kernel(flags, workdir)
                if bind is not None:
                    runs[f"{name} ({' '.join(flags)})"] = bind(mech)
        runs["numpy, hand-written, chunks of 8192"] = numpy_kernel(mech)
        sym = sympy_kernel(mech)
        if sym is None:
            print("sympy is not installed: its baseline is skipped (pip install 'linkdyn[bench]')")
        else:
            runs["sympy.mechanics, lambdified, chunks of 8192"] = sym
        for name, run in runs.items():
            check(name, run, mech, tc)
        times = {name: best_time(lambda: run(t, np.empty((ROWS, T))), args.repeat, args.time)
                 for name, run in runs.items()}
    finally:
        shutil.rmtree(workdir, ignore_errors=True)

    linkdyn.analyze(mech, t[:1000], backend="compiled")   # the kernels loaded (or compiled)
    per = {name: x / T for name, x in times.items()}
    per["linkdyn compiled"] = best_time(lambda: linkdyn.analyze(mech, t, backend="compiled"),
                                        args.repeat, args.time) / T
    solve = batch(mech, args.designs, 360)
    solve()
    per[f"linkdyn compiled, {args.designs} designs x 360 samples in one batch"] = best_time(
        solve, args.repeat, args.time) / (args.designs * 360)
    per["linkdyn numpy"] = best_time(lambda: linkdyn.analyze(mech, t, backend="numpy"),
                                     max(1, args.repeat - 1), args.time) / T

    ref_name = next(iter(per))
    ref = per[ref_name]
    print(f"Hoeken's full inverse dynamics (18 numbers per sample), {T} samples, one core, "
          f"best of {args.repeat} ({args.clock} clock); ratio: the time per sample of "
          f"{ref_name} over each one's")
    for name, x in per.items():
        print(f"  {name:62s} {x * 1e9:8.1f} ns/sample   ratio {ref / x:6.3f}")
    single, batched = (per[k] for k in list(per)[-3:-1])
    if ref_name.startswith("C, scalar"):
        print("linkdyn compiled, one mechanism, against scalar C:")
        print(verdict(ref / single, TARGET_SINGLE))
        print(f"linkdyn compiled, {args.designs} designs in one batch, against scalar C:")
        print(verdict(ref / batched, TARGET_BATCH))
    for name in runs:
        if name.startswith(("numpy", "sympy")):
            print(f"  linkdyn compiled {'ahead of' if single < per[name] else 'behind'} "
                  f"{name.split(',')[0]} ({per[name] / single:.2f} x its speed)")

    # where linkdyn's compiled time goes: each kernel alone, outputs already touched
    from bench_kernels import kernel_arguments, steps
    kernels = kernel_arguments(mech, t)
    print("linkdyn compiled by stage (each kernel alone, outputs already touched):")
    total = 0.0
    for name, (kernel, kargs) in kernels.items():
        x = best_time(lambda: kernel(*kargs), args.repeat, args.time) / T
        total += x
        name += " and reactions" if name == "dynamics" and "reactions" not in kernels else ""
        print(f"  {name:28s} {x * 1e9:8.1f} ns/sample")
    print(f"  {'the three kernels':28s} {total * 1e9:8.1f} ns/sample; the rest of analyze "
          f"(allocating and first touching the outputs, Python) "
          f"{(per['linkdyn compiled'] - total) * 1e9:.1f}")
    print("  one analyze call by stage (the least of a few calls each):")
    for name, x in analyze_stages(mech, t, args.repeat, args.time).items():
        print(f"    {name:48s} {x / T * 1e9:8.1f} ns/sample")
    print("  one call's CPU split, the least of a few (the system's part: page faults of fresh "
          "outputs):")
    shares = {"linkdyn compiled": lambda: linkdyn.analyze(mech, t, backend="compiled")}
    if ref_name.startswith("C, scalar"):
        shares[ref_name] = lambda: runs[ref_name](t, np.empty((ROWS, T)))
    for name, fn in shares.items():
        user, system, faults = system_share(fn, T, args.repeat)
        print(f"    {name:44s} user {user * 1e9:6.1f}, system {system * 1e9:6.1f} ns/sample,"
              f" {faults} page faults")
    print("  the kinematics kernel, step by step (called block by block from Python, a few ns "
          "of the calls each):")
    by_step(*steps(kernels["kinematics"][1]), T, args)
    print("  the dynamics kernel (with the reactions), step by step (called as above):")
    by_step(*dynamics_steps(kernels["dynamics"][1]), T, args)


def by_step(table, block, T, args):
    """Print each step of ``table`` (a function of a block ``(k0, nb)``) run over the ``T``
    samples block by block, in ns a sample."""
    for name, fn in table.items():
        fn(0, block)
        x = best_time(lambda: [fn(k0, min(block, T - k0)) for k0 in range(0, T, block)],
                      args.repeat, args.time) / T
        print(f"    {name:36s} {x * 1e9:8.1f} ns/sample")


if __name__ == "__main__":
    main()
