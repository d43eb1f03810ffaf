"""Throughput of linkdyn's spatial inverse dynamics on one core, beside Pinocchio (issue 24).

For the bundled RSUR four-bar and Stewart platform (``examples/spatial/rsur.toml``,
``stewart.toml``) it times ``linkdyn.analyze`` over N samples of one run (every state, driver
effort and joint reaction; spatial models run the numpy path, ``linkdyn.spatial``), the best
of ``--repeat`` runs, and prints samples/s and where the time goes, stage by stage (one more
run with each stage's function wrapped by a timer):

- kinematics: the drivers' motions; closing the loops (continuation and Newton's method,
  ``spatial.kinematics.assemble_designs``); the poses, closure Jacobian, twists and twist
  rates (``motion_at``); the singular-position test (``singular_samples``); the cut joints'
  own coordinates and rates (``joint_coordinates``);
- loads (``spatial.dynamics.loads``);
- dynamics: ``w*``, the composite wrenches, ``Q`` (``generalized``) and the driver efforts and
  multipliers ``[E_d, J^T] x = Q`` (``efforts``);
- reactions: the rest of ``spatial.dynamics.solve`` (the reactions, and where statics leaves
  them undetermined the minimum-norm solution);
- the rest of ``analyze`` (the solution object, the redundant rows at the first sample).

Measured in the same run for the Stewart platform: a Python loop over Pinocchio's dynamics of
the same mechanism, built from linkdyn's own MJCF export (``linkdyn export --to mjcf``) by
``pinocchio.buildModelAndLegacyConstraintsFromMJCF`` (the open tree, its five cut ball joints
as ``CONTACT_3D`` constraint models). Pinocchio is handed linkdyn's closed positions, rates and
accelerations (its own kinematics is not timed: a baseline that favours it), and per sample
the loop computes

- **inverse**: ``rnea`` (the open tree's generalized forces with gravity), the payload's
  generalized force from the frame Jacobian at its point, the constraints' Jacobian
  (``computeJointJacobians``, each constraint's ``calc``, ``getConstraintsJacobian``), and the actuator forces and the five
  ball joints' forces from ``[S, Jc^T] x = rnea - J_T^T F`` (``numpy.linalg.solve``, 21 x 21):
  the job ``analyze``'s dynamics does, without the other joints' reactions;
- **forward**: ``constraintDynamics`` (Pinocchio's constrained forward dynamics: the
  accelerations and constraint forces given the actuator forces, linkdyn's, and the payload).

Before timing, both loops are checked against linkdyn: the Pinocchio tree's points move as
linkdyn's (positions, velocities, accelerations), the inverse loop's actuator forces are
linkdyn's, and the forward loop's accelerations are linkdyn's, each to a fraction of its peak
that the script prints (and exits with an error beyond 1e-10).

Usage: python benchmarks/bench_spatial.py [--samples N] [--repeat R] [--clock cpu|wall]
                                          [--pinocchio-samples M] [--only rsur|stewart]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import xml.etree.ElementTree as ET  # noqa: E402
from contextlib import contextmanager  # noqa: E402

import numpy as np  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn.io.export import export  # noqa: E402
from linkdyn.spatial import algebra as sa  # noqa: E402
from linkdyn.spatial import dynamics as sd  # noqa: E402
from linkdyn.spatial import kinematics as sk  # noqa: E402

TARGETS = {"rsur": 2e6, "stewart": 2e5}   # samples/s, issue 24 (one core, compiled backend)
TARGET_RATIO = 10.0                         # Stewart: linkdyn against the Pinocchio loop
AGREE = 1e-10                               # Pinocchio's numbers from linkdyn's, of their peaks
MODELS = {"rsur": "RSUR four-bar", "stewart": "Stewart platform (6-UPS)"}

#: the stages and the functions they time (module, name); "reactions" and "the rest" are what
#: ``spatial.dynamics.solve`` and ``analyze`` spend outside the ones named
STAGES = (
    ("kinematics: the drivers' motions", sk, "driver_motions"),
    ("kinematics: closing the loops (continuation, Newton)", sk, "assemble_designs"),
    ("kinematics: poses, J, twists, twist rates", sk, "motion_at"),
    ("kinematics: singular-position test", sk, "singular_samples"),
    ("kinematics: cut joints' coordinates and rates", sk, "joint_coordinates"),
    ("loads", sd, "loads"),
    ("dynamics: w*, composite wrenches, Q", sd, "generalized"),
    ("dynamics: efforts and multipliers", sd, "efforts"),
    ("dynamics and reactions (all of spatial.dynamics.solve)", sd, "solve"),
)


def one_core():
    """Pin this process to one core (where the system allows)."""
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})


def best_time(fn, repeat, clock):
    """The least of ``repeat`` runs of ``fn``, s; and the last run's result."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = clock()
        out = fn()
        best = min(best, clock() - t0)
    return best, out


@contextmanager
def timed_stages(clock):
    """Wrap each stage's function (:data:`STAGES`) by a timer; yields the dict of seconds."""
    spent = {label: 0.0 for label, _, _ in STAGES}
    saved = []
    for label, module, name in STAGES:
        fn = getattr(module, name)

        def wrapper(*a, _fn=fn, _label=label, **k):
            t0 = clock()
            try:
                return _fn(*a, **k)
            finally:
                spent[_label] += clock() - t0
        saved.append((module, name, fn))
        setattr(module, name, wrapper)
    try:
        yield spent
    finally:
        for module, name, fn in saved:
            setattr(module, name, fn)


def linkdyn_rate(key, n, repeat, clock):
    """Time ``linkdyn.analyze`` of the bundled model ``key`` at ``n`` samples over one run."""
    model = linkdyn.load(linkdyn.example_path(f"spatial/{key}"))
    t = np.linspace(0.0, 1.0, n)                           # one crank turn; the heave and roll
    linkdyn.analyze(model, t[:64])                         # imports, expression compilation
    seconds, sol = best_time(lambda: linkdyn.analyze(model, t), repeat, clock)
    total_split = np.inf
    for _ in range(max(1, repeat - 1)):                    # the split: the least total of runs
        with timed_stages(clock) as spent:
            t0 = clock()
            linkdyn.analyze(model, t)
            total = clock() - t0
        if total < total_split:
            total_split, split = total, dict(spent)
    print(f"\n[{MODELS[key]}]  {n} samples (t = 0..1 s), one core, {CLOCK_NAME} time, best of "
          f"{repeat}")
    print(f"  linkdyn.analyze (numpy)       {seconds:9.3f} s   {n / seconds:12.4g} samples/s"
          f"   ({1e9 * seconds / n:9.0f} ns/sample)")
    target = TARGETS[key]
    print(f"  issue 24's target (compiled)  {target:12.4g} samples/s: the numpy path is "
          f"{target * seconds / n:.0f} times short")
    print(f"  by stage (one run with timers, {1e9 * total_split / n:.0f} ns/sample in all), "
          "ns/sample:")
    named = 0.0
    for label, _, name in STAGES:
        if name in ("generalized", "efforts"):
            continue
        if name == "solve":
            dyn = split["dynamics: w*, composite wrenches, Q"] + split[
                "dynamics: efforts and multipliers"]
            for what, s in (("dynamics: w*, composite wrenches, Q",
                             split["dynamics: w*, composite wrenches, Q"]),
                            ("dynamics: efforts and multipliers",
                             split["dynamics: efforts and multipliers"]),
                            ("reactions (minimum norm)", split[label] - dyn)):
                print(f"    {what:<54s}{1e9 * s / n:9.0f}")
        else:
            print(f"    {label:<54s}{1e9 * split[label] / n:9.0f}")
        named += split[label]
    print(f"    {'the rest of analyze':<54s}{1e9 * (total_split - named) / n:9.0f}")
    return model, t, sol, n / seconds


# ---------------------------------------------------------------- Pinocchio
def pinocchio_model(model):
    """Pinocchio's model and loop constraints of a spatial ``model`` from linkdyn's MJCF.

    Two edits of the exported file, both for Pinocchio's MJCF reader (4.1): the keyframe is
    left out (the reader compares its size with another count and refuses it), and the
    bodies on the world are put in one massless body fixed to it (the reader reads only the
    first body on the world)."""
    import pinocchio as pin
    root = ET.fromstring(export(model, "mjcf").text)
    for key in root.findall("keyframe"):
        root.remove(key)
    world = root.find("worldbody")
    base = ET.Element("body", name="linkdyn_base")
    ET.SubElement(base, "inertial", pos="0 0 0", mass="0", diaginertia="0 0 0")
    for child in list(world):
        world.remove(child)
        base.append(child)
    world.append(base)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "model.xml")
        ET.ElementTree(root).write(path)
        pm, constraints = pin.buildModelAndLegacyConstraintsFromMJCF(path)
    return pm, constraints


def pinocchio_state(model, sol, pm):
    """Pinocchio's ``q, v, a`` (T, nq), (T, nv), (T, nv) of linkdyn's motion: hinges and slides
    are linkdyn's joint coordinates (MJCF ``qpos = q_<name>``); a ball joint's quaternion is
    the child's rotation from its place on the parent, its rate and acceleration the relative
    angular velocity in the child's frame and its rate."""
    import pinocchio as pin
    cols = sol.columns()
    T = len(sol.t)
    q, v, a = np.zeros((T, pm.nq)), np.zeros((T, pm.nv)), np.zeros((T, pm.nv))
    p, m = sol.plan, sol.motion
    data = pm.createData()
    balls = []
    for jid in range(1, pm.njoints):
        joint, name = pm.joints[jid], pm.names[jid]
        if joint.shortname() == "JointModelSpherical":
            balls.append((jid, name))
            q[:, joint.idx_q + 3] = 1.0                     # (x, y, z, w): the identity
            continue
        names = ([name] if joint.shortname() != "JointModelComposite"
                 else [name.removeprefix("Composite_")[:-2] + s for s in (".1", ".2")])
        for k, c in enumerate(names):
            q[:, joint.idx_q + k] = cols[f"q_{c}"]
            v[:, joint.idx_v + k] = cols[f"qd_{c}"]
            a[:, joint.idx_v + k] = cols[f"qdd_{c}"]
    for jid, name in balls:
        jt = model.joint(name)
        parent, child = p.topo.bodies.index(jt.body_a), p.topo.bodies.index(jt.body_b)
        RP, RC = m.tree.R[:, parent], m.tree.R[:, child]
        wP, wC = m.V[:, parent, :3], m.V[:, child, :3]
        aP, aC = m.A[:, parent, :3], m.A[:, child, :3]
        joint = pm.joints[jid]
        for k in range(T):
            pin.forwardKinematics(pm, data, q[k])          # the ball at identity: its place
            place = data.oMi[pm.parents[jid]].rotation @ pm.jointPlacements[jid].rotation
            rel = place.T @ RC[k]
            q[k, joint.idx_q:joint.idx_q + 4] = pin.Quaternion(rel).coeffs()
        v[:, joint.idx_v:joint.idx_v + 3] = sa.matvec(sa.transpose(RC), wC - wP)
        a[:, joint.idx_v:joint.idx_v + 3] = sa.matvec(sa.transpose(RC),
                                                      aC - aP + sa.cross(wC, wP))
    return q, v, a


def payload(model, pm):
    """The payload forces: (frame id, force (3,), N) of each constant force load."""
    out = []
    for ld in model.loads:
        assert ld.kind == "force", ld.kind
        out.append((pm.getFrameId(f"{ld.body}.{ld.point}"),
                    np.asarray(ld.value(np.zeros(1)), float).reshape(3)))
    return out


def pinocchio_inverse(pm, constraints, S, loads, q, v, a):
    """The Python loop: per sample the actuator forces and constraint forces (T, 21)."""
    import pinocchio as pin
    data = pm.createData()
    cdata = [c.createData() for c in constraints]
    out = np.empty((len(q), S.shape[1] + 3 * len(constraints)))
    world = pin.LOCAL_WORLD_ALIGNED
    for k in range(len(q)):
        rhs = pin.rnea(pm, data, q[k], v[k], a[k])
        pin.computeJointJacobians(pm, data, q[k])
        pin.updateFramePlacements(pm, data)
        for frame, force in loads:
            rhs = rhs - pin.getFrameJacobian(pm, data, frame, world)[:3].T @ force
        for c, cd in zip(constraints, cdata):           # the constraints' placements
            c.calc(pm, data, cd)
        Jc = pin.getConstraintsJacobian(pm, data, constraints, cdata)
        out[k] = np.linalg.solve(np.hstack([S, Jc.T]), rhs)
    return out


def pinocchio_forward(pm, constraints, S, loads, q, v, tau):
    """The Python loop: per sample ``constraintDynamics``' accelerations (T, nv) given the
    actuator forces ``tau`` (T, n_d) and the payload."""
    import pinocchio as pin
    data = pm.createData()
    cdata = [c.createData() for c in constraints]
    pin.initConstraintDynamics(pm, data, constraints, cdata)
    settings = pin.ProximalSettings(1e-14, 0.0, 1)
    out = np.empty((len(q), pm.nv))
    world = pin.LOCAL_WORLD_ALIGNED
    for k in range(len(q)):
        u = S @ tau[k]
        if loads:
            pin.computeJointJacobians(pm, data, q[k])
            pin.updateFramePlacements(pm, data)
            for frame, force in loads:
                u = u + pin.getFrameJacobian(pm, data, frame, world)[:3].T @ force
        out[k] = pin.constraintDynamics(pm, data, q[k], v[k], u, constraints, cdata, settings)
    return out


def check_points(model, sol, pm, q, v, a, rows, samples):
    """The largest difference of Pinocchio's points from linkdyn's (positions, velocities,
    accelerations), each as a fraction of its largest value, at Pinocchio's states ``rows``,
    linkdyn's ``samples``."""
    import pinocchio as pin
    data = pm.createData()
    cols = sol.columns()
    worst = 0.0
    for prefix in ("", "v", "a"):
        peak = max(np.max(np.abs(cols[f"{prefix}{c}_{b.name}.{pt}"]))
                   for b in model.moving_bodies for pt in b.points for c in "xyz")
        for r, k in zip(rows, samples):
            pin.forwardKinematics(pm, data, q[r], v[r], a[r])
            pin.updateFramePlacements(pm, data)
            for b in model.moving_bodies:
                for pt in b.points:
                    f = pm.getFrameId(f"{b.name}.{pt}")
                    got = {"": data.oMf[f].translation,
                           "v": pin.getFrameVelocity(pm, data, f, pin.LOCAL_WORLD_ALIGNED).linear,
                           "a": pin.getFrameClassicalAcceleration(
                               pm, data, f, pin.LOCAL_WORLD_ALIGNED).linear}[prefix]
                    want = np.array([cols[f"{prefix}{c}_{b.name}.{pt}"][k] for c in "xyz"])
                    worst = max(worst, float(np.max(np.abs(got - want))) / peak)
    return worst


def baseline(model, sol, m_samples, repeat, clock, linkdyn_rate_):
    """The Pinocchio loops on the Stewart platform's first ``m_samples`` samples."""
    try:
        import pinocchio as pin
    except ImportError:
        print("  Pinocchio: not installed (pip install pin), no baseline")
        return
    pm, constraints = pinocchio_model(model)
    q, v, a = pinocchio_state(model, sol, pm)
    S = np.zeros((pm.nv, len(model.drivers)))
    for c, d in enumerate(model.drivers):
        S[pm.joints[pm.getJointId(d.joint)].idx_v, c] = 1.0
    loads = payload(model, pm)
    tau = np.stack([sol.columns()[f"force_{d.joint}"] for d in model.drivers], -1)
    idx = np.linspace(0, len(q) - 1, min(m_samples, len(q))).round().astype(int)
    q, v, a, tau = q[idx], v[idx], a[idx], tau[idx]
    # the same job: the same points, actuator forces and accelerations
    check = np.linspace(0, len(idx) - 1, 5).round().astype(int)
    points = check_points(model, sol, pm, q, v, a, check, idx[check])
    x = pinocchio_inverse(pm, constraints, S, loads, q, v, a)
    force = np.max(np.abs(x[:, :S.shape[1]] - tau)) / np.max(np.abs(tau))
    acc = pinocchio_forward(pm, constraints, S, loads, q, v, tau)
    accel = np.max(np.abs(acc - a)) / np.max(np.abs(a))
    print(f"  Pinocchio {pin.__version__} (a Python loop over {len(idx)} samples of the same "
          "run, linkdyn's motion given):")
    print(f"    agrees with linkdyn: points {points:.1e}, actuator forces {force:.1e}, "
          f"accelerations {accel:.1e} of their peaks")
    if max(points, force, accel) > AGREE:
        raise SystemExit(f"Pinocchio's loops do not do linkdyn's job (beyond {AGREE:g} of the "
                         "peaks): no comparison")
    inv, _ = best_time(lambda: pinocchio_inverse(pm, constraints, S, loads, q, v, a), repeat,
                       clock)
    fwd, _ = best_time(lambda: pinocchio_forward(pm, constraints, S, loads, q, v, tau), repeat,
                       clock)
    for what, s in (("inverse (rnea, Jc, [S, Jc^T] solve)", inv),
                    ("forward (constraintDynamics)", fwd)):
        rate = len(idx) / s
        print(f"    {what:<40s}{rate:12.4g} samples/s   linkdyn / Pinocchio "
              f"{linkdyn_rate_ / rate:8.3f}")
    ratio = linkdyn_rate_ * inv / len(idx)
    print(f"  ratio to the inverse loop   {ratio:12.3f}   (target >= {TARGET_RATIO:g}, compiled: "
          f"{'met' if ratio >= TARGET_RATIO else 'NOT met'})")


def main():
    global CLOCK_NAME
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=20000)
    ap.add_argument("--pinocchio-samples", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--clock", choices=("wall", "cpu"), default="cpu")
    ap.add_argument("--only", choices=tuple(MODELS))
    args = ap.parse_args()
    clock = time.process_time if args.clock == "cpu" else time.perf_counter
    CLOCK_NAME = "CPU" if args.clock == "cpu" else "wall"
    one_core()
    for key in MODELS:
        if args.only and key != args.only:
            continue
        model, t, sol, rate = linkdyn_rate(key, args.samples, args.repeat, clock)
        if key == "stewart":
            baseline(model, sol, args.pinocchio_samples, args.repeat, clock, rate)


CLOCK_NAME = "CPU"

if __name__ == "__main__":
    main()
