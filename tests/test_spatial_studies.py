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
    data["analysis"] = {"duration": 0.25, "samples": 5}
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
    t = np.linspace(0.0, 0.25, 5)
    _same_columns(linkdyn.analyze(m, t).columns(), linkdyn.analyze(m2, t).columns())
    # and the unposed file's run: the pose is only a choice of body frames
    plain = linkdyn.load(linkdyn.example_path("rsur"))
    a, b = linkdyn.analyze(plain, t).columns(), linkdyn.analyze(m2, t).columns()
    for k in ("tau_J1", "Fx_J4", "Mz_J3", "x_coupler.C", "kinetic_energy"):
        scale = max(float(np.max(np.abs(a[k]))), 1e-12)
        np.testing.assert_allclose(b[k], a[k], rtol=0, atol=1e-9 * scale, err_msg=k)


# --- design studies -----------------------------------------------------------------------

def test_a_sweep_of_a_point_coordinate_gives_each_design_analyzed_alone(tmp_path):
    """rsur's crank pin B moved out of the crank's plane (a 3-vector's component): each row's
    peak and RMS driving torque and peak joint forces are those of that file analyzed alone."""
    path = "bodies.crank.points.B[2]"
    t = np.linspace(0.0, 0.3, 4)
    values = np.array([-8.0, 8.0])
    df = linkdyn.sweep(linkdyn.example_path("rsur"), {path: values}, t)
    assert df["valid"].all() and list(df[path]) == list(values)
    data = tomllib.loads(linkdyn.example_path("rsur").read_text())
    for k, z in enumerate(values):
        data["bodies"][1]["points"]["B"][2] = float(z)
        src = tmp_path / f"d{k}.toml"
        src.write_text(dumps_toml(data))
        alone = linkdyn.analyze(linkdyn.load(src), t)
        tau = alone.effort("J1")
        assert df["peak_tau_J1"][k] == np.max(np.abs(tau))
        assert df["rms_tau_J1"][k] == pytest.approx(np.sqrt(np.mean(tau ** 2)), rel=1e-14)
        for j in ("J1", "J2", "J3", "J4"):
            f = np.linalg.norm(alone.reaction(j)[:, :3], axis=1)
            assert df[f"peak_F_{j}"][k] == np.max(f), j
    assert df["peak_tau_J1"][0] != df["peak_tau_J1"][1]   # the parameter reached the model
    sp = linkdyn.studies.space(linkdyn.example_path("stewart"), [
        "joints[0].axis[1]", "bodies.cylinder1.rotation[0]", "bodies.cylinder1.origin[2]",
        "loads[0].value[2]"])
    assert [p.unit for p in sp.params] == ["", "rad", "mm", "N"]


# the designs of test_a_batched_spatial_sweep_is_each_design_analyzed_alone: the crank pin out of
# the crank's plane and the crank's length (120 mm: the loop cannot close over a whole turn), the
# coupler's mass, the load on the rocker, gravity and the crank's speed (other continuation nodes)
BATCH = {"bodies.crank.points.B[2]": [-8.0, 0.0, 8.0, 0.0, 3.0, -5.0, 6.0],
         "bodies.crank.points.B[0]": [40.0, 42.0, 38.0, 120.0, 45.0, 35.0, 40.0],
         "bodies.coupler.mass": [0.55, 0.8, 0.3, 0.55, 0.55, 1.2, 0.55],
         "loads[0].value[2]": [-20.0, -20.0, 5.0, -20.0, -35.0, -20.0, 0.0],
         "mechanism.gravity[2]": [-9.81, -9.81, -9.81, -9.81, 0.0, -3.0, -9.81],
         "drivers[0].motion.rpm": [60.0, 60.0, 60.0, 60.0, 60.0, 60.0, 150.0]}


def test_a_batched_spatial_sweep_is_each_design_analyzed_alone(tmp_path):
    """rsur's designs solved as one batch (every stage over all designs' samples, each design's
    own continuation and Newton masks): each valid row's metrics are those of its own file,
    written out and analyzed alone, to 1e-12 of their scale; the design that cannot close has
    the message linkdyn.analyze raises for its file (without the file name)."""
    from linkdyn.spatial.shaking import shaking_force

    t = np.linspace(0.0, 1.0, 61)
    df = linkdyn.sweep(linkdyn.example_path("rsur"), BATCH, t)
    assert list(df["valid"]) == [True, True, True, False, True, True, True]
    data = tomllib.loads(linkdyn.example_path("rsur").read_text())
    for k in range(len(df)):
        data["bodies"][1]["points"]["B"][2] = BATCH["bodies.crank.points.B[2]"][k]
        data["bodies"][1]["points"]["B"][0] = BATCH["bodies.crank.points.B[0]"][k]
        data["bodies"][2]["mass"] = BATCH["bodies.coupler.mass"][k]
        data["loads"][0]["value"][2] = BATCH["loads[0].value[2]"][k]
        data["mechanism"]["gravity"][2] = BATCH["mechanism.gravity[2]"][k]
        data["drivers"][0]["motion"]["rpm"] = BATCH["drivers[0].motion.rpm"][k]
        src = tmp_path / f"d{k}.toml"
        src.write_text(dumps_toml(data))
        if not df["valid"][k]:
            with pytest.raises(linkdyn.AssemblyError) as err:
                linkdyn.analyze(linkdyn.load(src), t)
            assert str(err.value) == f"{src}: {df['reason'][k]}"
            assert all(np.isnan(df[c][k]) for c in df.columns if c.startswith(("peak", "rms")))
            continue
        alone = linkdyn.analyze(linkdyn.load(src), t)
        tau = alone.effort("J1")
        expect = {"peak_tau_J1": np.max(np.abs(tau)), "rms_tau_J1": np.sqrt(np.mean(tau ** 2)),
                  "peak_shaking_force": np.max(np.linalg.norm(shaking_force(alone), axis=1))}
        for j in ("J1", "J2", "J3", "J4"):
            expect[f"peak_F_{j}"] = np.max(np.linalg.norm(alone.reaction(j)[:, :3], axis=1))
        for name, v in expect.items():
            assert abs(df[name][k] - v) <= 1e-12 * abs(v), (k, name)
    # the parameters reached the models: the coupler's mass, the speed
    assert len(set(np.round(df["peak_tau_J1"][df["valid"]], 9))) == 6


def _each_kind_as_tree_and_cut():
    import copy

    from test_spatial import DEAD_CENTRE, rscr, slider_crank
    out = [(name, linkdyn.load(linkdyn.example_path(name))) for name in spatial_example_names()]
    off = copy.deepcopy(DEAD_CENTRE)          # the crank pin off the slider's line, the crank
    off["bodies"][1]["points"]["A"][1] = off["bodies"][2]["points"]["A"][1] = 0.02   # driven
    off["drivers"] = [{"joint": "J1", "motion": {"kind": "constant_speed", "rpm": 60.0}}]
    for name, data, cut in (("slider_crank", slider_crank(), None), ("rscr", rscr(), None),
                            ("slider_crank_cut_universal", slider_crank(), ["J3"]),
                            ("rscr_cut_cylindrical", rscr(), ["J3"]),
                            ("planar_slider_crank_cut_prismatic", off, ["J4"])):
        if cut:
            data["topology"] = {"cut": cut}
        out.append((name, linkdyn.io.model_from_dict(data)))
    return out


def test_a_batch_of_every_spatial_model_is_each_design_alone():
    """Every bundled spatial model that analyze takes, and the slider-crank and RSCR with each
    joint kind as a tree and as a cut joint: two designs in one batch (the second's bodies
    heavier, its springs and dampers stiffer; a damper added beside each spring) give each
    design's efforts, reactions, kinetic energy and coordinates alone, to 1e-12 of each one's
    scale."""
    from dataclasses import replace

    from linkdyn import spatial
    t = np.linspace(0.0, 0.2, 5)
    done = []
    for name, m in _each_kind_as_tree_and_cut():
        try:
            alone = [linkdyn.analyze(m, t)]
        except linkdyn.LinkdynError:      # a model for simulate (free coordinates)
            continue
        springs = [ld for ld in m.loads if ld.kind == "spring"]
        if springs:      # a damper beside each spring, and other constants in the second design
            m = replace(m, loads=list(m.loads) + [replace(ld, kind="damper", name="", damping=3.0)
                                                  for ld in springs])
            alone = [linkdyn.analyze(m, t)]
        heavy = replace(m, bodies=[replace(b, mass=2.0 * b.mass, inertia=3.0 * b.inertia)
                                   for b in m.bodies],
                        loads=[replace(ld, stiffness=2.0 * ld.stiffness, damping=2.0 * ld.damping,
                                       free_length=0.9 * ld.free_length) for ld in m.loads])
        alone.append(linkdyn.analyze(heavy, t))
        sol, kept, errors = spatial.analyze_designs([m, heavy], t)
        assert list(kept) == [0, 1] and errors == [None, None] and sol.batch == (2, 5), name
        for k, one in enumerate(alone):
            rows = slice(5 * k, 5 * k + 5)
            for got, ref in ((sol.dynamics.tau[rows], one.dynamics.tau),
                             (sol.dynamics.reactions[rows], one.dynamics.reactions),
                             (sol.dynamics.kinetic_energy[rows], one.dynamics.kinetic_energy),
                             (sol.motion.q[rows], one.motion.q)):
                scale = max(float(np.max(np.abs(ref), initial=0.0)), 1e-300)
                np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * scale, err_msg=name)
        done.append(name)
    assert {"rsur", "stewart", "spatial_slider_crank", "slider_crank_cut_universal",
            "rscr_cut_cylindrical", "planar_slider_crank_cut_prismatic"} <= set(done)


def test_a_design_at_a_dead_centre_in_a_batch_keeps_its_message():
    """A slider-crank driven by its slider from the crank pin's height y: at y = 0 crank and
    rod are in line at t = 0 (a dead centre, exit 3 alone); solved in one batch with designs
    off the line, it is invalid with the message analyze raises for it alone, and the others
    have the metrics they have alone."""
    import copy

    from test_spatial import DEAD_CENTRE as data

    t = np.linspace(0.0, 0.2, 5)
    ys = [0.02, 0.0, -0.03]
    df = linkdyn.sweep(data, {"bodies.crank.points.A[1]": ys, "bodies.rod.points.A[1]": ys}, t)
    assert list(df["valid"]) == [True, False, True]
    for k, y in enumerate(ys):
        one = copy.deepcopy(data)
        one["bodies"][1]["points"]["A"][1] = one["bodies"][2]["points"]["A"][1] = y
        if k == 1:
            with pytest.raises(linkdyn.AssemblyError, match="singular position") as err:
                linkdyn.analyze(linkdyn.io.model_from_dict(one), t)
            err.value.file = ""
            assert df["reason"][k] == str(err.value)
            continue
        alone = linkdyn.analyze(linkdyn.io.model_from_dict(one), t)
        force = alone.effort("J4")
        assert df["peak_force_J4"][k] == pytest.approx(np.max(np.abs(force)), rel=1e-12, abs=0)
        for j in ("J1", "J2", "J3", "J4"):
            v = np.max(np.linalg.norm(alone.reaction(j)[:, :3], axis=1))
            assert df[f"peak_F_{j}"][k] == pytest.approx(v, rel=1e-12, abs=0), j


def test_a_spatial_optimize_finds_the_design_of_the_per_design_path(monkeypatch):
    """linkdyn.optimize of rsur's crank pin height scores its designs by the batch; scored
    instead by each design's own linkdyn.analyze (the per-design path, written here), the
    same seeded search ends at the same design with the same objective."""
    from linkdyn.studies import optimize as opt
    from linkdyn.studies import runner

    bounds = {"bodies.crank.points.B[2]": (-10.0, 10.0)}
    t = np.linspace(0.0, 1.0, 25)
    kw = dict(minimize="peak_F_J2", popsize=4, maxiter=4, polish=False)
    batched = linkdyn.optimize(linkdyn.example_path("rsur"), bounds, t, **kw)

    def alone(task, values):
        values = np.atleast_2d(values)
        out = {"valid": np.ones(len(values), bool), "reason": np.full(len(values), "", object)}
        for name in task.metrics:
            out[name] = np.full(len(values), np.nan)
        for k, v in enumerate(values):
            sol = linkdyn.analyze(task.space.model(v), task.t)
            for name in task.metrics:
                j = name[len("peak_F_"):]
                out[name][k] = np.max(np.linalg.norm(sol.reaction(j)[:, :3], axis=1))
        return out
    monkeypatch.setattr(opt, "evaluate", alone)
    monkeypatch.setattr(runner, "evaluate", alone)
    single = linkdyn.optimize(linkdyn.example_path("rsur"), bounds, t, **kw)
    path = "bodies.crank.points.B[2]"
    assert batched.values[path] == pytest.approx(single.values[path], rel=1e-9, abs=1e-9)
    assert batched.metrics["peak_F_J2"] == pytest.approx(single.metrics["peak_F_J2"], rel=1e-12)
    assert batched.history == pytest.approx(single.history, rel=1e-12)


def test_peak_torque_metric_of_spatial_designs(tmp_path):
    """A crank about +x under gravity with a load at its tip: tau = cos(phi) (m g c + F L), so
    the sweep's peak_tau_J1 over the mass centre's coordinate c is |m g c + F L| (closed form),
    and each row equals that design analyzed alone."""
    src = tmp_path / "crank.toml"
    src.write_text(CRANK)
    t = np.linspace(0.0, 0.25, 3)   # phi = 0, 45, 90 deg: the peak at phi = 0
    c = np.array([-40.0, -10.0, 25.0])
    df = linkdyn.sweep(src, {"bodies.crank.com[1]": c}, t)
    np.testing.assert_allclose(df["peak_tau_J1"], np.abs(1.0 * 9.81 * c * 1e-3 + 2.0 * 0.1),
                               rtol=1e-12)
    data = tomllib.loads(CRANK)
    for k, ck in enumerate(c):
        data["bodies"][1]["com"][1] = float(ck)
        one = tmp_path / f"c{k}.toml"
        one.write_text(dumps_toml(data))
        sol = linkdyn.analyze(linkdyn.load(one), t)
        assert df["peak_tau_J1"][k] == np.max(np.abs(sol.effort("J1")))
        assert df["peak_F_J1"][k] == np.max(np.linalg.norm(sol.reaction("J1")[:, :3], axis=1))
    with pytest.raises(linkdyn.ModelError, match="planar models only"):
        linkdyn.sweep(src, {"bodies.crank.com[1]": c}, t, metrics=["path_deviation"])
    with pytest.raises(linkdyn.ModelError, match="compiled backend is not yet for spatial"):
        linkdyn.sweep(src, {"bodies.crank.com[1]": c}, t, backend="compiled")


def _draws_both_designs(path, panels: int) -> None:
    """compare.html in Chromium: every panel holds both designs' curves, the hover reads both,
    no script error (skipped where Chromium or playwright is missing, as test_report's)."""
    from test_report import CHROMIUM_ARGS, _chromium, _unavailable
    exe = _chromium()
    if exe is None:
        _unavailable("Chromium is not installed (apt-get install chromium)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _unavailable("playwright is not installed (pip install playwright)")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1440, "height": 900})
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(path.as_uri())
        page.wait_for_function("window.__linkdynCompare === true")
        assert page.locator("#plots path.series").count() == 2 * panels
        page.locator("#plots .panel svg").first.scroll_into_view_if_needed()
        box = page.locator("#plots .panel svg").first.bounding_box()
        page.mouse.move(box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"])
        assert page.locator("#plots .tooltip b[data-design]").count() == 2
        assert errors == []
        browser.close()


CRANK = """
[mechanism]
name = "crank"
space = "spatial"
gravity = [0.0, 0.0, -9.81]

[units]
length = "mm"
angle = "deg"

[[bodies]]
name = "ground"
points = { O = [0.0, 0.0, 0.0] }

[[bodies]]
name = "crank"
points = { O = [0.0, 0.0, 0.0], B = [0.0, 100.0, 0.0] }
mass = 1.0
com = [0.0, 30.0, 0.0]
inertia = [2000.0, 500.0, 2000.0]

[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O", "crank.O"]
axis = [1.0, 0.0, 0.0]

[[drivers]]
joint = "J1"
motion = { kind = "constant_speed", rpm = 60.0, start = 0.0 }

[[loads]]
kind = "force"
body = "crank"
point = "B"
value = [0.0, 0.0, -2.0]
"""


def test_the_stewart_platform_follows_its_trajectory():
    """The bundled 6-UPS platform: its six leg lengths (drivers by formulas) are the closed-form
    inverse kinematics of a heave 20 sin(pi t) mm and a roll 0.1 sin(2 pi t) rad about x, so the
    platform's centre and rotation solved from them are that trajectory; mobility 6."""
    m = linkdyn.load(linkdyn.example_path("stewart"))
    t = np.linspace(0.0, 1.0, 5)
    sol = linkdyn.analyze(m, t)
    a, h = 0.1 * np.sin(2 * np.pi * t), 0.02 * np.sin(np.pi * t)
    centre = np.stack([0 * t, 0 * t, 0.25 + h], axis=1)
    np.testing.assert_allclose(sol.point("platform", "T"), centre, rtol=0, atol=1e-13)
    c, s = np.cos(a), np.sin(a)
    rx = np.stack([np.stack([1 + 0 * t, 0 * t, 0 * t], -1), np.stack([0 * t, c, -s], -1),
                   np.stack([0 * t, s, c], -1)], axis=1)
    np.testing.assert_allclose(sol.rotation("platform"), rx, rtol=0, atol=1e-13)
    assert len(m.drivers) == 6 and linkdyn.spatial.check(m)["mobility"] == 6


def test_compare_two_spatial_models_writes_its_page(tmp_path):
    """compare of rsur and rsur with its crank pin lifted: compare.json holds each design's
    own summary (as linkdyn analyze writes it), compare.html its curves and key results; a
    planar model beside them is refused (exit 2)."""
    import json

    from click.testing import CliRunner

    from linkdyn.cli import main
    data = tomllib.loads(linkdyn.example_path("rsur").read_text())
    data["bodies"][1]["points"]["B"][2] = 8.0
    lifted = tmp_path / "lifted.toml"
    lifted.write_text(dumps_toml(data))
    rsur = str(linkdyn.example_path("rsur"))
    run = CliRunner().invoke
    short = ["--samples", "4", "--duration", "0.3"]
    res = run(main, ["compare", rsur, str(lifted), *short, "-o", str(tmp_path / "c")])
    assert res.exit_code == 0, res.output
    out = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert list(out) == ["rsur", "lifted"]
    for name, path in (("rsur", rsur), ("lifted", str(lifted))):
        res = run(main, ["analyze", path, *short, "-o", str(tmp_path / name)])
        assert res.exit_code == 0, res.output
        alone = json.loads((tmp_path / name / "summary.json").read_text())
        assert out[name]["summary"]["peak_effort"] == alone["peak_effort"]
        assert out[name]["summary"]["peak_reaction"] == alone["peak_reaction"]
    assert out["rsur"]["summary"]["peak_effort"] != out["lifted"]["summary"]["peak_effort"]
    page = (tmp_path / "c" / "compare.html").read_text()
    blob = json.loads(page.split('type="application/json">', 1)[1].split("</script>", 1)[0])
    for d in blob["designs"]:   # the key results of each design's own report page
        key = {it["label"]: it["value"] for it in d["key"]}
        peak = out[d["name"]]["summary"]["peak_effort"]["tau_J1"]
        assert max(key["max torque J1"], -key["min torque J1"]) == pytest.approx(peak, rel=1e-12)
    assert [p["key"] for p in blob["panels"]] == ["tau:J1", "F:J1", "F:J2", "F:J3", "F:J4",
                                                  "M:J1", "M:J3", "M:J4"]
    # in Chromium: every panel with both designs' curves
    _draws_both_designs(tmp_path / "c" / "compare.html", panels=8)
    res = run(main, ["compare", rsur, str(linkdyn.example_path("hoeken")), "-o",
                     str(tmp_path / "mixed")])
    assert res.exit_code == 2 and "not both" in res.output


SLIDER = """
[mechanism]
space = "spatial"
gravity = [0.0, -9.81, -3.0]
[[bodies]]
name = "ground"
points = { O = [0.0, 0.0, 0.0] }
[[bodies]]
name = "slider"
points = { O = [0.0, 0.0, 0.0] }
mass = 2.0
inertia = [0.01, 0.01, 0.01]
[[joints]]
name = "P"
type = "prismatic"
connect = ["ground.O", "slider.O"]
axis = [0.6, 0.8, 0.0]
[[drivers]]
joint = "P"
motion = { kind = "expression", q = "0.1*sin(3*t)" }
"""


@pytest.mark.parametrize("name, applied", [
    ("spatial_slider_crank", [-40.0, 0.0, -30.0]), ("rps3", [0.0, 0.0, -30.0]),
    ("slider", [0.0, 0.0, 0.0])])
def test_spatial_shaking_force_is_the_moving_bodies_momentum_balance(name, applied, tmp_path):
    """peak_shaking_force's force on the ground (joint reactions, a ground prismatic driver's
    effort, the return spring anchored on the ground) equals sum(m g + F) - sum(m a_G), F the
    loads not from the ground and a_G the mass centres' accelerations (kinematics alone)."""
    from linkdyn.io import model_from_dict
    from linkdyn.spatial.shaking import shaking_force
    data = tomllib.loads(SLIDER if name == "slider" else linkdyn.example_path(name).read_text())
    for b in data["bodies"][1:]:
        b["points"]["G_"] = b.get("com", [0.0, 0.0, 0.0])
    m = model_from_dict(data)
    t = np.linspace(0.0, 0.5, 5)
    sol = linkdyn.analyze(m, t)
    balance = np.zeros((len(t), 3)) + applied
    for b in m.bodies[1:]:
        balance += b.mass * (np.asarray(m.gravity) - sol.point_acceleration(b.name, "G_"))
    got = shaking_force(sol)
    np.testing.assert_allclose(got, balance, rtol=0, atol=1e-12 * np.max(np.abs(balance)))
    metric = linkdyn.studies.evaluate_metrics(sol, ["peak_shaking_force"])
    assert metric["peak_shaking_force"] == np.max(np.linalg.norm(got, axis=1))


def test_sweep_and_optimize_commands_on_a_spatial_model(tmp_path):
    """One parameter (the crank's mass centre y, mm): linkdyn optimize reaches the best of a
    dense scan by linkdyn sweep, and the closed form's c = -F L / (m g); it writes best.toml (a
    spatial model file at that value), the best design's spatial summary and its report page."""
    import json

    from click.testing import CliRunner

    from linkdyn.cli import main
    src = tmp_path / "crank.toml"
    src.write_text(CRANK)
    run = CliRunner().invoke
    short = ["--samples", "3", "--duration", "0.25"]   # a quarter turn: the peak at phi = 0
    res = run(main, ["sweep", str(src), "--vary", "bodies.crank.com[1]=-60:60:13", *short,
                     "-o", str(tmp_path / "s")])
    assert res.exit_code == 0, res.output
    scan = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert scan["valid"] == 13
    best_scan = scan["metrics"]["peak_tau_J1"]
    res = run(main, ["optimize", str(src), "--vary", "bodies.crank.com[1]=-60:60", *short,
                     "--minimize", "peak_tau_J1", "--popsize", "3", "--maxiter", "3",
                     "--report", "-o", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    info = json.loads((tmp_path / "o" / "optimize.json").read_text())
    c = info["parameters"]["bodies.crank.com[1]"]
    assert info["metrics"]["peak_tau_J1"] <= best_scan["best"]
    assert abs(c - (-60.0 + 10.0 * best_scan["best_design"])) <= 10.0   # within the scan's step
    assert abs(c - (-2.0 * 100.0 / 9.81)) < 0.5
    best = linkdyn.load(tmp_path / "o" / "best.toml")
    assert best.space == "spatial" and best.body("crank").com[1] == pytest.approx(c * 1e-3,
                                                                                 rel=1e-12)
    alone = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert alone["peak_effort"]["tau_J1"] == pytest.approx(info["metrics"]["peak_tau_J1"],
                                                           rel=1e-12)
    # the best design's report page, the spatial one linkdyn analyze --report writes
    page = (tmp_path / "o" / "report.html").read_text()
    assert '"dim":3' in page.replace(" ", "") and "plot_efforts.png" not in info["files"]
    # headed by the objective, and the run's results.csv beside it (3 samples)
    assert "Optimized: peak_tau_J1 minimized" in page
    head = (tmp_path / "o" / "results.csv").read_text().splitlines()
    assert len(head) == 4 and "tau_J1" in head[0].split(",")
