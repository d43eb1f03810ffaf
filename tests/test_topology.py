"""Topology: mobility (Grübler–Kutzbach), loops, spanning tree, cut joints, malformed graphs.

Models are the bundled examples, or the bundled Hoeken four-bar edited as text so each bad
model reads as "Hoeken, except ...".
"""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

import linkdyn
from linkdyn import kinematics, topology
from linkdyn.cli import example_names, example_text
from linkdyn.errors import ModelError
from linkdyn.io import model_from_dict

HOEKEN = example_text("hoeken")

# name: (bodies incl. ground, joints, mobility, loops, cut joints chosen)
EXPECTED = {
    "hoeken": (4, 4, 1, 1, ["J4"]),            # [topology] cut = ["J4"] in the file
    "drag_link": (4, 4, 1, 1, ["J4"]),
    "slider_crank": (4, 4, 1, 1, ["J4"]),
    "inverted_slider_crank": (4, 4, 1, 1, ["J3"]),
    "fivebar": (5, 5, 2, 1, ["J4"]),           # two drivers: J1 and J5 (the last joint)
    "stephenson": (6, 7, 1, 2, ["J4", "J7"]),
    "watt2": (6, 7, 1, 2, ["J4", "J7"]),
    "scotch_yoke": (3, 3, 1, 1, ["J3"]),      # the slot is always cut
    "geared_fivebar": (5, 6, 1, 2, ["G", "J5"]),  # the gear pair is always cut
    "cam_follower": (3, 3, 1, 1, ["K"]),      # the cam joint is always cut
    "cam_fourbar": (5, 6, 1, 2, ["J5", "K"]),
    "cam_flat_rocker": (3, 3, 1, 1, ["K"]),
}


def edit(text: str, old: str, new: str) -> str:
    """Replace ``old`` (which must occur) by ``new``."""
    assert old in text, f"test setup: {old!r} not in the model text"
    return text.replace(old, new)


def model(text: str, source: str = "hoeken-edited.toml"):
    return model_from_dict(tomllib.loads(text), source=source)


def build(text: str):
    return topology.build(model(text))


def model_error(text: str) -> ModelError:
    """The ModelError raised while reading ``text`` or building its topology."""
    with pytest.raises(ModelError) as info:
        topology.build(model(text))
    return info.value


def joint_names(mech, indices):
    return [mech.joints[j].name for j in indices]


DRIVER_J1 = 'joint = "J1"\nmotion = { kind = "constant_speed", rpm = 45.0, start = 0.0 }\n'


# ------------------------------------------------------------------------ the bundled examples

def test_every_example_is_covered():
    assert sorted(EXPECTED) == example_names()


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_mobility_loops_and_cuts_of_examples(name):
    mech = linkdyn.load(linkdyn.example_path(name))
    topo = topology.build(mech)
    n_bodies, n_joints, mobility, loops, cuts = EXPECTED[name]
    assert (topo.n, len(mech.joints)) == (n_bodies, n_joints)
    # Grübler–Kutzbach: a revolute or prismatic joint removes 2 freedoms, a slot or a gear
    # pair or a cam 1; and one driver per degree of freedom
    removed = sum(1 if j.kind in ("slot", "gear", "rack", "cam", "rocker_cam", "flat_cam",
                                  "rocker_flat_cam") else 2 for j in mech.joints)
    assert topo.mobility == mobility == 3 * (n_bodies - 1) - removed
    assert len(mech.drivers) == mobility
    # independent loops = joints - (bodies - 1): one cut joint per loop
    assert topo.n_loops == loops == n_joints - n_bodies + 1
    assert joint_names(mech, topo.cut) == cuts


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_spanning_tree_structure(name):
    mech = linkdyn.load(linkdyn.example_path(name))
    topo = topology.build(mech)
    assert topo.bodies[0] == "ground" and topo.parent[0] == -1
    assert sorted(topo.bodies) == sorted(b.name for b in mech.bodies)
    tree = set()
    for i in range(1, topo.n):
        assert 0 <= topo.parent[i] < i
        jt = mech.joints[topo.tree_joint[i]]
        # the tree joint joins body i to its parent; sign says which end body i is
        pair = {jt.body_a, jt.body_b}
        assert pair == {topo.bodies[i], topo.bodies[topo.parent[i]]}
        assert (jt.body_b if topo.sign[i] == 1 else jt.body_a) == topo.bodies[i]
        tree.add(topo.tree_joint[i])
    # tree joints and cut joints partition the joints
    assert tree.isdisjoint(topo.cut)
    assert tree | set(topo.cut) == set(range(len(mech.joints)))
    # ancestors[i, k]: body k's tree joint lies on the ground -> i path
    for i in range(1, topo.n):
        path, k = set(), i
        while k > 0:
            path.add(k)
            k = topo.parent[k]
        assert set(np.flatnonzero(topo.ancestors[i])) == path


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_cut_joints_are_never_driven(name):
    mech = linkdyn.load(linkdyn.example_path(name))
    topo = topology.build(mech)
    driven = {d.joint for d in mech.drivers}
    assert driven.isdisjoint(joint_names(mech, topo.cut))
    # each driver moves the tree joint of its body, in the order of model.drivers
    assert [mech.joints[topo.tree_joint[i]].name for i in topo.driven] == [
        d.joint for d in mech.drivers]
    assert sorted(topo.driven + topo.dependent) == list(range(1, topo.n))


def test_fivebar_does_not_cut_its_last_joint_although_it_closes_the_loop():
    # J5 is last in file order, so a plain file-order Kruskal would cut it; it is driven
    mech = linkdyn.load(linkdyn.example_path("fivebar"))
    topo = topology.build(mech)
    assert "J5" not in joint_names(mech, topo.cut)
    assert topo.mobility == 2 and topo.n_loops == 1


# ------------------------------------------------------------------------ cut joints

def test_without_topology_section_a_cut_is_chosen_automatically():
    text = edit(HOEKEN, '[topology]\ncut = ["J4"]\n', "")
    mech = model(text)
    assert mech.cut is None
    topo = topology.build(mech)
    assert topo.n_loops == 1 and joint_names(mech, topo.cut) == ["J4"]


def test_automatic_cut_avoids_a_driven_joint_that_closes_the_loop():
    # drive J4 (the joint that closes the loop in file order) instead of J1
    text = edit(HOEKEN, '[topology]\ncut = ["J4"]\n', "")
    text = edit(text, DRIVER_J1, DRIVER_J1.replace('"J1"', '"J4"'))
    mech = model(text)
    topo = topology.build(mech)
    cuts = joint_names(mech, topo.cut)
    assert len(cuts) == 1 and cuts != ["J4"]
    assert mech.joints[topo.tree_joint[topo.driven[0]]].name == "J4"


def test_automatic_cut_prefers_a_slider():
    # the inverted slider-crank declares the ground pivot J4 last, yet its slider J3 is cut: a
    # cut slider leaves a loop that closes in closed form (an RPR dyad)
    mech = linkdyn.load(linkdyn.example_path("inverted_slider_crank"))
    assert mech.cut is None and mech.joint("J3").kind == "prismatic"
    topo = topology.build(mech)
    assert joint_names(mech, topo.cut) == ["J3"]
    # the slider-crank's slider is its last joint anyway
    mech = linkdyn.load(linkdyn.example_path("slider_crank"))
    assert [mech.joints[j].kind for j in topology.build(mech).cut] == ["prismatic"]


@pytest.mark.parametrize("cut", ["J2", "J3"])
def test_user_cut_is_honoured_and_gives_the_same_motion(cut):
    text = edit(HOEKEN, 'cut = ["J4"]', f'cut = ["{cut}"]')
    mech = model(text)
    topo = topology.build(mech)
    assert joint_names(mech, topo.cut) == [cut]
    assert all(topo.parent[i] < i for i in range(1, topo.n))
    # the motion does not depend on where the loop is cut
    t = np.linspace(0.0, 4 / 3, 13)
    ref = kinematics.solve(linkdyn.load(linkdyn.example_path("hoeken")), t)
    kin = kinematics.solve(mech, t)
    assert kin.valid.all()
    np.testing.assert_allclose(kin.q, ref.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(kin.qd, ref.qd, rtol=0, atol=1e-8 * np.abs(ref.qd).max())
    np.testing.assert_allclose(kin.qdd, ref.qdd, rtol=0, atol=1e-8 * np.abs(ref.qdd).max())


def test_cutting_a_driven_joint_is_refused():
    err = model_error(edit(HOEKEN, 'cut = ["J4"]', 'cut = ["J1"]'))
    assert err.field == "topology.cut[0]"
    assert "'J1'" in err.message and "driven" in err.message


def test_cutting_joints_that_disconnect_the_mechanism():
    err = model_error(edit(HOEKEN, 'cut = ["J4"]', 'cut = ["J3", "J4"]'))
    assert err.field == "topology.cut"
    assert "'rocker'" in err.message and "path to the ground" in err.message
    assert "J3" in err.message and "J4" in err.message
    assert "one per loop" in err.fix


def test_cutting_an_unknown_joint_suggests_the_spelling():
    err = model_error(edit(HOEKEN, 'cut = ["J4"]', 'cut = ["j4"]'))
    assert err.field == "topology.cut[0]"
    assert "'J4'" in err.fix


# ------------------------------------------------------------------------ malformed graphs

LONELY = '\n[[bodies]]\nname = "lonely"\npoints = { A = [0.0, 0.0] }\nmass = 1.0\ninertia = 1.0\n'


def test_dangling_body():
    err = model_error(HOEKEN + LONELY)
    assert err.field == "bodies.lonely"
    assert err.file == "hoeken-edited.toml"
    assert "body 'lonely' is not connected to the ground" in err.message
    assert "hoeken-edited.toml: bodies.lonely:" in str(err)


def test_two_bodies_joined_to_each_other_but_not_to_the_ground():
    text = (HOEKEN + LONELY + LONELY.replace("lonely", "buddy")
            + '\n[[joints]]\nname = "J9"\ntype = "revolute"\nconnect = ["lonely.A", "buddy.A"]\n')
    err = model_error(text)
    assert err.field in ("bodies.lonely", "bodies.buddy")
    assert "not connected to the ground" in err.message


PENDULUM = ('\n[[bodies]]\nname = "pendulum"\npoints = { A = [0.0, 0.0] }\nmass = 1.0\n'
            'inertia = 1.0\n\n[[joints]]\nname = "J5"\ntype = "revolute"\n'
            'connect = ["coupler.P", "pendulum.A"]\n')


def test_under_driven():
    # a pendulum hung from the coupler point adds a freedom that nothing drives
    err = model_error(HOEKEN + PENDULUM)
    assert err.field == "drivers"
    assert "mobility 2" in err.message and "1 driver(s)" in err.message
    assert "3*(5-1) - 2*5" in err.message and "5 bodies" in err.message
    assert "Add 1 driver(s)" in err.fix


def test_over_driven():
    text = edit(HOEKEN, "[assembly]", "[[drivers]]\n" + DRIVER_J1.replace('"J1"', '"J2"')
                + "\n[assembly]")
    err = model_error(text)
    assert err.field == "drivers"
    assert "mobility 1" in err.message and "2 driver(s)" in err.message
    assert "Remove 1 driver(s)" in err.fix


def test_over_constrained_structure():
    # a fifth pin between crank and rocker makes 4 bodies / 5 joints: mobility -1
    text = edit(HOEKEN, "[[drivers]]", '[[joints]]\nname = "J5"\ntype = "revolute"\n'
                'connect = ["crank.O2", "rocker.O3"]\n\n[[drivers]]')
    err = model_error(text)
    assert "mobility -1" in err.message and "3*(4-1) - 2*5" in err.message
    assert "over-constrain" in err.fix


def test_two_drivers_closing_a_loop_among_themselves():
    # five-bar with J1, J5 driven: cutting J5 by hand must be refused at read time
    five = example_text("fivebar")
    with pytest.raises(ModelError) as info:
        model(five + '\n[topology]\ncut = ["J5"]\n')
    assert info.value.field == "topology.cut[0]" and "'J5'" in info.value.message


def test_topology_is_static_integers():
    topo = topology.build(linkdyn.load(linkdyn.example_path("watt2")))
    for seq in (topo.parent, topo.tree_joint, topo.sign, topo.cut, topo.driven, topo.dependent):
        assert isinstance(seq, tuple) and all(isinstance(x, int) for x in seq)
    assert set(topo.sign[1:]) <= {1, -1}


def _chain_model(n: int):
    """A serial chain of ``n`` driven revolute links built in Python (no file)."""
    from linkdyn.model import Body, Driver, Joint, Model
    from linkdyn.motion import ConstantSpeed

    pts = {"A": np.zeros(2), "B": np.array([1.0, 0.0])}
    bodies = [Body("ground", {"A": np.zeros(2)})] + [
        Body(f"b{i}", pts, mass=1.0, inertia=1.0) for i in range(1, n + 1)]
    joints = [Joint(f"J{i}", "revolute", "ground" if i == 1 else f"b{i - 1}",
                    "A" if i == 1 else "B", f"b{i}", "A") for i in range(1, n + 1)]
    drivers = tuple(Driver(f"J{i}", ConstantSpeed(1.0)) for i in range(1, n + 1))
    return Model("chain", tuple(bodies), tuple(joints), drivers)


@pytest.mark.parametrize("n", [20_000, 60_000])
def test_topology_is_linear_in_bodies(n):
    import gc
    import time

    mech = _chain_model(n)
    gc.collect()                         # the garbage collector's pass over the model just built
    start = time.process_time()          # CPU time: other processes on the machine do not count
    topo = topology.build(mech)
    elapsed = time.process_time() - start
    assert elapsed < 1.5, f"{n}-body chain took {elapsed:.2f} s"   # was 16 s (20,000), a hang (60,000)
    assert topo.n == n + 1 and topo.parent == (-1, *range(n)) and topo.cut == ()
    assert topo.tree_joint[1:] == tuple(range(n)) and set(topo.sign[1:]) == {1}
    assert topo.driven == tuple(range(1, n + 1)) and topo.dependent == ()
    if n > 20_000:
        return
    short = dataclasses.replace(mech, drivers=mech.drivers[1:])      # the error path too
    start = time.process_time()
    with pytest.raises(ModelError, match=f"mobility {n} .* but {n - 1} driver"):
        topology.build(short)
    assert time.process_time() - start < 1.5


def test_ancestors_follow_the_parents():
    topo = build(example_text("stephenson"))
    for i in range(topo.n):        # independent walk up the tree
        path, k = set(), i
        while k > 0:
            path.add(k)
            k = topo.parent[k]
        assert set(np.flatnonzero(topo.ancestors[i])) == path
    assert topo.ancestors is topo.ancestors and not topo.ancestors.flags.writeable
