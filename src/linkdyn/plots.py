"""Static figures (matplotlib, Agg): ``linkdyn analyze --plots`` and ``linkdyn reproduce``.

matplotlib is imported only when a figure is drawn, and only through ``matplotlib.figure.Figure``
(no pyplot, no global state, no display needed). Display units: angles in degrees, everything
else SI.

- :func:`outputs`: ``plot_joints``, ``plot_efforts``, ``plot_reactions``, ``plot_multipliers``
  (when a loop is cut), ``plot_paths``, each as PNG and SVG.
  A curve against time is drawn by its envelope at the axes' pixel columns (``_curve``: peaks
  and gaps kept); a figure is laid out once for all its formats (``_save``).
- :func:`reproduce`: the seed paper's Figs. 5-7 for its worked example (Hoeken's linkage), with
  their data as CSV, a ``README.txt`` and ``reproduce.json`` saying what each figure shows.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .errors import ModelError
from . import joints as jk
from .model import GROUND

DEG = 180.0 / math.pi
MAX_POINTS = 20000  # points drawn per traced path (x against y); longer runs are strided
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#bcbd22", "#7f7f7f")
DPI = 120


def _figure(w: float, h: float):
    from matplotlib.figure import Figure
    return Figure(figsize=(w, h), dpi=DPI, layout="constrained")


def _save(fig, path, ext: str | None = None) -> None:
    """Save ``fig`` as ``ext`` (by default the path's suffix) at :data:`DPI`.

    The constrained layout is computed once, at the first save, and then kept: otherwise each
    ``savefig`` lays the figure out again and draws it twice (once to measure it), which is
    most of a figure's cost; the second format of a figure is drawn once, in the same layout.
    """
    engine = fig.get_layout_engine()
    if engine is not None:
        import matplotlib
        engine.execute(fig)
        with matplotlib.rc_context({"figure.autolayout": False,
                                    "figure.constrained_layout.use": False}):
            fig.set_layout_engine(None)   # the positions just computed stay
    fig.savefig(path, format=ext, dpi=DPI)


def _envelope(x: np.ndarray, y: np.ndarray, columns: int):
    """``(x, y)`` reduced to what a line drawn through every sample shows at ``columns`` pixel
    columns: the samples cut into ``columns`` runs of equal length, of each its first, last,
    lowest and highest sample (peaks kept exactly) and its first NaN (a gap stays a gap).

    Parameters
    ----------
    x, y : (n,) arrays
        A curve, ``x`` increasing (time, or a crank angle), in any units.
    columns : int
        Pixel columns: runs at most ``columns`` long are returned whole.

    Returns
    -------
    x, y : (m,) arrays, ``m <= 5 columns``, a subsequence of the samples in their order.
    """
    x, y = np.asarray(x), np.asarray(y)
    n = len(y)
    if n <= 4 * columns:
        return x, y
    w = -(-n // columns)                       # samples per column
    yy = np.full(columns * w, np.nan)
    yy[:n] = y
    yy = yy.reshape(columns, w)
    gap = np.isnan(yy)
    start = np.arange(columns) * w
    picks = np.stack([start, np.minimum(start + w - 1, n - 1),
                      start + np.where(gap, np.inf, yy).argmin(axis=1),
                      start + np.where(gap, -np.inf, yy).argmax(axis=1),
                      start + gap.argmax(axis=1)], axis=1)
    k = np.unique(picks[picks < n])
    return x[k], y[k]


def _curve(ax, x, y, **style):
    """``ax.plot`` of the curve ``y(x)`` (``x`` increasing) by its :func:`_envelope` at the
    axes' pixel columns: its share of the figure's width at :data:`DPI` (the layout's margins
    only make the drawn axes narrower)."""
    spec = ax.get_subplotspec()
    share = 1.0 if spec is None else len(spec.colspan) / spec.get_gridspec().ncols
    columns = math.ceil(ax.figure.get_figwidth() * share * DPI)
    return ax.plot(*_envelope(x, y, columns), **style)


def _style(ax, xlabel: str = "", ylabel: str = "", title: str = "") -> None:
    ax.grid(True, color="#e3e6ea", lw=0.8)
    ax.margins(x=0)
    ax.axhline(0.0, color="#9aa3ab", lw=0.8, zorder=0)
    if xlabel:
        ax.set_xlabel(xlabel)
    if ylabel:
        ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title, loc="left", fontsize=10, fontweight="bold")


def _stride(n: int, max_points: int = MAX_POINTS) -> np.ndarray:
    if n <= max_points:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_points)).astype(int))


# ------------------------------------------------------------------------ analyze --plots

def outputs(sol, formats: tuple[str, ...] = ("png", "svg")) -> dict:
    """``{"plot_<name>.<ext>": writer(path)}`` for every figure of :func:`figures`.

    Each figure is drawn once and saved in every format.
    """
    builders = figure_builders(sol)
    cache: dict = {}

    def writer(name, ext):
        def write(path: Path) -> None:
            if name not in cache:
                cache[name] = builders[name](sol)
            _save(cache[name], path, ext)
            if ext == formats[-1]:
                cache.pop(name, None)  # drawn in every format: free it
        return write

    return {f"plot_{name}.{ext}": writer(name, ext) for name in builders for ext in formats}


# the figure each section of a report page's panels becomes (panel_outputs)
SECTION_FIGURES = {"Joint motion (relative joint coordinates q)": "joints", "Link motion": "links",
                   "Point motion": "points", "Driver efforts and joint reactions": "efforts",
                   "Energy": "energy"}


def panel_outputs(data: dict, formats: tuple[str, ...] = ("png", "svg")) -> dict:
    """``{"plot_<name>.<ext>": writer(path)}``: each section of a report page's panels (the
    ``plots`` of ``report.spatial.page_data``) as one figure of its panels against time,
    named by :data:`SECTION_FIGURES`: what ``--plots`` writes for a spatial model."""
    t = np.asarray(data["t"], float)
    sections: dict[str, list] = {}
    for spec in data["plots"]:
        if spec.get("kind") != "polar" and "x" not in spec:
            sections.setdefault(spec["section"], []).append(spec)

    def build(title, specs):
        ncol = min(3, len(specs))
        nrow = math.ceil(len(specs) / ncol)
        fig = _figure(4.2 * ncol, 2.6 * nrow + 0.5)
        axes = np.asarray(fig.subplots(nrow, ncol, sharex=True, squeeze=False)).ravel()
        for ax, spec in zip(axes, specs):
            for ser in spec["series"]:
                y = np.array([np.nan if v is None else v for v in data["series"][ser["key"]]])
                _curve(ax, t, y, lw=1.4, color=ser["color"], label=ser["label"])
            _style(ax, "t (s)", spec["unit"], spec["title"])
            ax.legend(fontsize=7, ncols=min(len(spec["series"]), 4), loc="best")
        for ax in axes[len(specs):]:
            ax.set_visible(False)
        fig.suptitle(f"{data['name']}: {title.lower()}", fontsize=11)
        return fig

    cache: dict = {}

    def writer(title, specs, ext):
        def write(path: Path) -> None:   # each figure drawn once, saved in every format
            fig = cache.pop(title, None) or build(title, specs)
            _save(fig, path, ext)
            if ext != formats[-1]:
                cache[title] = fig
        return write

    return {f"plot_{SECTION_FIGURES.get(sec, sec.split()[0].lower())}.{ext}": writer(sec, specs, ext)
            for sec, specs in sections.items() for ext in formats}


def figure_builders(sol) -> dict:
    """Names and builder functions ``f(sol) -> Figure`` of the figures for this solution."""
    b = {"joints": fig_joints, "efforts": fig_efforts, "reactions": fig_reactions}
    if len(sol.topology.cut):
        b["multipliers"] = fig_multipliers
    b["paths"] = fig_paths
    return b


def figures(sol) -> dict:
    """All figures: name -> ``matplotlib.figure.Figure``."""
    return {name: f(sol) for name, f in figure_builders(sol).items()}


def fig_joints(sol):
    """Joint coordinates, rates and accelerations vs time (revolute in deg, rad/s, rad/s^2;
    prismatic in m, m/s, m/s^2)."""
    m, t = sol.model, sol.t
    groups = [g for g in ([j for j in m.joints if jk.get(j.kind).angular],
                          [j for j in m.joints if not jk.get(j.kind).angular]) if g]
    fig = _figure(6.4 * len(groups), 8.0)
    axes = np.asarray(fig.subplots(3, len(groups), sharex=True, squeeze=False))
    rows = (("q", "angle", "displacement", ("deg", "m")), ("qd", "rate", "rate", ("rad/s", "m/s")),
            ("qdd", "acceleration", "acceleration", ("rad/s²", "m/s²")))
    for c, js in enumerate(groups):
        rev = jk.get(js[0].kind).angular
        for r, (key, wr, wp, units) in enumerate(rows):
            ax = axes[r, c]
            for j in js:
                y = sol.columns[f"{key}_{j.name}"] * (DEG if (rev and key == "q") else 1.0)
                _curve(ax, t, y, lw=1.5, color=PALETTE[m.joints.index(j) % len(PALETTE)],
                       label=j.name)
            word = wr if rev else wp
            _style(ax, "t (s)" if r == 2 else "", f"{units[0 if rev else 1]}",
                   f"Joint {word}s ({'angular' if rev else 'linear'})")
            ax.legend(fontsize=8, ncols=min(len(js), 4), loc="best")
    fig.suptitle(f"{m.name}: joint motion (q = second body relative to first)", fontsize=11)
    return fig


def fig_efforts(sol):
    """Driver torques (N m) and forces (N) vs time."""
    m, t = sol.model, sol.t
    groups = [(u, [(n, d) for n, d in enumerate(m.drivers)
                   if jk.get(m.joint(d.joint).kind).angular == (u == "N m")]) for u in ("N m", "N")]
    groups = [g for g in groups if g[1]]
    fig = _figure(7.0, 2.6 * max(len(groups), 1) + 0.6)
    axes = np.atleast_1d(fig.subplots(max(len(groups), 1), 1, sharex=True, squeeze=False)[:, 0])
    for ax, (unit, ds) in zip(axes, groups):
        for n, d in ds:
            _curve(ax, t, sol.dyn.tau[:, n], lw=1.6,
                   color=PALETTE[[j.name for j in m.joints].index(d.joint) % len(PALETTE)],
                   label=f"{d.joint} ({d.description})" if d.description else d.joint)
        _style(ax, "t (s)", unit, f"Driver {'torque' if unit == 'N m' else 'force'}")
        ax.legend(fontsize=8)
    fig.suptitle(f"{m.name}: driver efforts (on the driven joint's second body)", fontsize=11)
    return fig


def fig_reactions(sol):
    """|F| of every joint, then Fx, Fy per joint (by the joint's first body on its second)."""
    m, t = sol.model, sol.t
    nj = len(m.joints)
    ncol = 3 if nj > 4 else 2
    nrow = 1 + math.ceil(nj / ncol)
    fig = _figure(4.2 * ncol, 2.5 * nrow + 0.4)
    gs = fig.add_gridspec(nrow, ncol)
    ax0 = fig.add_subplot(gs[0, :])
    F = sol.reactions.force
    for n, j in enumerate(m.joints):
        _curve(ax0, t, np.linalg.norm(F[:, n], axis=-1), lw=1.5,
               color=PALETTE[n % len(PALETTE)], label=j.name)
    _style(ax0, "t (s)", "N", "Reaction force magnitude |F|")
    ax0.legend(fontsize=8, ncols=min(nj, 7))
    for n, j in enumerate(m.joints):
        ax = fig.add_subplot(gs[1 + n // ncol, n % ncol], sharex=ax0)
        _curve(ax, t, F[:, n, 0], lw=1.4, color=PALETTE[0], label="Fx")
        _curve(ax, t, F[:, n, 1], lw=1.4, color=PALETTE[3], label="Fy")
        if "M" in jk.get(j.kind).reaction:
            ax2 = ax.twinx()
            _curve(ax2, t, sol.reactions.moment[:, n], lw=1.2, ls="--", color=PALETTE[2],
                   label="M")
            ax2.set_ylabel("M (N m)", color=PALETTE[2])
            ax2.legend(fontsize=8, loc="lower right")
        _style(ax, "t (s)", "N", f"{j.name}: {j.body_a} on {j.body_b}")
        ax.legend(fontsize=8, loc="upper right")
    fig.suptitle(f"{m.name}: joint reactions (global components)", fontsize=11)
    return fig


def fig_multipliers(sol):
    """The cut-joint multipliers lam (reactions at the cut joints), one panel per cut joint."""
    from .report import multiplier_labels
    m, t = sol.model, sol.t
    labels = multiplier_labels(sol)
    cuts = list(dict.fromkeys(lbl[0] for lbl in labels))
    fig = _figure(7.0, 2.6 * len(cuts) + 0.6)
    axes = np.atleast_1d(fig.subplots(len(cuts), 1, sharex=True, squeeze=False)[:, 0])
    for ax, c in zip(axes, cuts):
        comps = [(n, lbl) for n, lbl in enumerate(labels) if lbl[0] == c]
        jt = m.joint(c)
        forces = [(n, lbl) for n, lbl in comps if lbl[2] == "N"]
        moments = [(n, lbl) for n, lbl in comps if lbl[2] != "N"]
        # forces on the panel's axis, moments (N m) on a twin axis
        for (n, lbl), col in zip(forces, (PALETTE[0], PALETTE[3])):
            _curve(ax, t, sol.dyn.lam[:, n], lw=1.5, color=col,
                   label=f"λ {lbl[1]}" + (" (N)" if moments else ""))
        if moments:
            ax2 = ax.twinx()
            for n, lbl in moments:
                _curve(ax2, t, sol.dyn.lam[:, n], lw=1.3, ls="--", color=PALETTE[3],
                       label=f"λ {lbl[1]} ({lbl[2]})")
            ax2.set_ylabel(moments[0][1][2])
            ax2.legend(fontsize=8, loc="lower right")
        unit = "N"
        _style(ax, "t (s)", unit, f"Cut joint {c}: reaction of {jt.body_a} on {jt.body_b}")
        ax.legend(fontsize=8, loc="upper right")
    fig.suptitle(f"{m.name}: cut-joint multipliers λ", fontsize=11)
    return fig


def draw_mechanism(ax, sol, frames, *, alpha_min: float = 0.18, mm: bool = True) -> None:
    """Draw the mechanism at the sample indices ``frames`` (faint to solid) with traced paths."""
    from .report.data import body_shape
    m = sol.model
    s = 1e3 if mm else 1.0
    colors = {b.name: PALETTE[n % len(PALETTE)] for n, b in enumerate(m.moving_bodies)}
    used = {f"{j.body_a}.{j.point_a}" for j in m.joints} | {
        f"{j.body_b}.{j.point_b}" for j in m.joints}
    k = _stride(len(sol.t))
    for b in m.moving_bodies:  # paths of all points; coupler points stand out
        for p in b.points:
            xy = sol.point(b.name, p)[k] * s
            coupler = f"{b.name}.{p}" not in used
            ax.plot(xy[:, 0], xy[:, 1], lw=1.6 if coupler else 0.8, ls="-" if coupler else ":",
                    color=colors[b.name], alpha=0.9 if coupler else 0.5,
                    label=f"path of {b.name}.{p}" if coupler else None)
    ground = m.body(GROUND)
    gp = np.array([ground.points[j.point_a if j.body_a == GROUND else j.point_b]
                   for j in m.joints if GROUND in (j.body_a, j.body_b)], float) * s
    if len(gp):
        ax.plot(gp[:, 0], gp[:, 1], "^", ms=11, color="#555", mfc="#e9ecef", zorder=5)
    for n, f in enumerate(frames):
        a = alpha_min + (1 - alpha_min) * (n + 1) / len(frames)
        for b in m.moving_bodies:
            shape, outline = body_shape(b.points)
            xy = np.array([sol.point(b.name, p)[f] for p in outline]) * s
            if shape == "polygon":
                ax.fill(xy[:, 0], xy[:, 1], color=colors[b.name], alpha=0.25 * a, lw=0)
                xy = np.vstack([xy, xy[:1]])
            ax.plot(xy[:, 0], xy[:, 1], "-", lw=3.5, color=colors[b.name], alpha=a,
                    solid_capstyle="round", label=b.name if n == len(frames) - 1 else None)
        for j in m.joints:
            xy = sol.point(j.body_b, j.point_b)[f] * s
            ax.plot(*xy, "o", ms=5, mfc="white", mec="#222", mew=1.2, alpha=a, zorder=6)
            if n == len(frames) - 1:
                ax.annotate(j.name, xy, xytext=(5, 5), textcoords="offset points", fontsize=8)
    ax.set_aspect("equal", adjustable="datalim")
    unit = "mm" if mm else "m"
    _style(ax, f"x ({unit})", f"y ({unit})")


def fig_paths(sol):
    """The mechanism at a few instants and the paths of its named points."""
    m = sol.model
    ok = np.flatnonzero(sol.valid)
    frames = ok[np.round(np.linspace(0, len(ok) - 1, 6)).astype(int)] if len(ok) else []
    fig = _figure(7.5, 6.0)
    ax = fig.add_subplot()
    draw_mechanism(ax, sol, list(frames)[:-1] if len(frames) > 1 else list(frames))
    ax.legend(fontsize=8, loc="best")
    ax.set_title(f"{m.name}: poses at 5 instants (latest darkest) and point paths",
                 fontsize=10, loc="left")
    return fig


# ------------------------------------------------------------------------ reproduce

SUPPORTED = ("hoeken",)


def reproduce(name: str):
    """Run a published example and draw the figures it is known by.

    Returns ``(sol, files)``: the solution and ``{filename: writer(path)}``.

    Raises
    ------
    ModelError
        ``name`` is not a supported reproduction (exit status 2).
    """
    if name not in SUPPORTED:
        raise ModelError(f"no reproduction named '{name}'", field="NAME",
                         fix="Supported: " + ", ".join(SUPPORTED))
    return reproduce_hoeken()


HOEKEN_RPM = 45.0
HOEKEN_SAMPLES = 361

HOEKEN_CONVENTIONS = [
    "Frame: X along the ground link from O1 (crank pivot, joint 1) to O4 (rocker pivot, joint 4), "
    "Y 90 deg counter-clockwise; angles counter-clockwise positive.",
    "theta_i = q_Ji, the relative joint angle at joint i: angle of the joint's second body minus "
    "that of its first. theta_1 = crank angle (ground -> crank), theta_2 = coupler - crank, "
    "theta_3 = rocker - coupler, theta_4 = q_J4 = rocker angle from the ground (J4 connects "
    "ground -> rocker). In the paper's loop convention joint 4 goes from the rocker back to the "
    "ground, so its theta_4 is -q_J4 (77.1 deg at t = 0, making theta_1 + ... + theta_4 = 0 mod "
    "360); its rate and acceleration change sign the same way.",
    "Joint rates are the time derivatives of theta_i (rad/s), accelerations their second "
    "derivatives (rad/s^2).",
    "lambda_1, lambda_2: the reaction at the cut joint 4, i.e. the force exerted BY the ground ON "
    "the rocker (link #3) along global X and Y, N (the paper's Fig. 3). They equal Fx_J4 and "
    "Fy_J4 of results.csv.",
    "Driving torque tau: the torque the motor at joint 1 applies on the crank, N m, positive "
    "counter-clockwise (tau_J1 in results.csv).",
    "Reaction at joint i (Fig. 7): the force exerted BY the joint's first body ON its second, "
    "global X and Y components, N: joint 1 ground on crank, joint 2 crank on coupler, joint 3 "
    "coupler on rocker. The force on the other body is the opposite.",
    "Horizontal plane (no gravity), frictionless joints, crank at a constant 45 rpm "
    "(4.7124 rad/s) from theta_1 = 0; one crank turn (4/3 s) sampled at 361 instants, one per "
    "degree of crank angle.",
]


def _hoeken_figure_specs():
    """Figures: name -> (file, paper figure, caption, panels); a panel is (title, unit,
    [(label, results.csv column, scale)])."""
    th = [(f"θ{i} (J{i})", f"q_J{i}", DEG) for i in range(1, 5)]
    return {
        "fig5": ("fig5_kinematics.png", "Fig. 5",
                 "Kinematic analysis of Hoeken's mechanism: (a) joint angles theta_i, (b) joint "
                 "rates, (c) joint accelerations, i = 1..4",
                 [("(a) Joint angles θi", "deg", th),
                  ("(b) Joint rates dθi/dt", "rad/s",
                   [(f"dθ{i}/dt (J{i})", f"qd_J{i}", 1.0) for i in range(1, 5)]),
                  ("(c) Joint accelerations d²θi/dt²", "rad/s²",
                   [(f"d²θ{i}/dt² (J{i})", f"qdd_J{i}", 1.0) for i in range(1, 5)])]),
        "fig6": ("fig6_multipliers_torque.png", "Fig. 6",
                 "Lagrange multipliers lambda_1, lambda_2 (reaction at the cut joint 4 along X "
                 "and Y) and the driving torque tau at joint 1",
                 [("(a) Lagrange multipliers at the cut joint 4", "N",
                   [("λ1 (X)", "Fx_J4", 1.0), ("λ2 (Y)", "Fy_J4", 1.0)]),
                  ("(b) Driving torque τ at joint 1", "N m", [("τ", "tau_J1", 1.0)])]),
        "fig7": ("fig7_reactions.png", "Fig. 7",
                 "Reaction forces at joints 1, 2 and 3 (X and Y components)",
                 [(f"({'abc'[i - 1]}) Joint {i}: {a} on {b}", "N",
                   [(f"R{i}x", f"Fx_J{i}", 1.0), (f"R{i}y", f"Fy_J{i}", 1.0)])
                  for i, (a, b) in enumerate((("ground", "crank"), ("crank", "coupler"),
                                              ("coupler", "rocker")), start=1)]),
    }


def reproduce_hoeken():
    """The seed paper's worked example: Figs. 5-7 (and Fig. 4, the mechanism)."""
    import linkdyn
    from .analysis import analyze

    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    period = 60.0 / HOEKEN_RPM
    t = np.linspace(0.0, period, HOEKEN_SAMPLES)
    sol = analyze(mech, t)
    cut = [mech.joints[c].name for c in sol.topology.cut]
    if cut != ["J4"]:  # the paper cuts joint 4; the bundled model must say so
        raise ModelError(f"the bundled Hoeken model cuts {cut}, the paper cuts ['J4']",
                         field="topology.cut", fix="Restore cut = [\"J4\"] in hoeken.toml")
    specs = _hoeken_figure_specs()
    cols = sol.columns
    x = cols["q_J1"] * DEG

    def data_table(panels):
        names = ["crank_angle_deg", "t_s"]
        data = [x, sol.t]
        for _, unit, series in panels:
            for label, col, scale in series:
                unit_tag = unit.replace(" ", "").replace("²", "2").replace("/", "_per_")
                names.append(f"{col}_{unit_tag}")
                data.append(cols[col] * scale)
        return names, np.column_stack(data)

    def fig_writer(key):
        def write(path: Path) -> None:
            _, paper, caption, panels = specs[key]
            fig = _paper_figure(sol, x, panels, f"{paper} (seed paper) reproduced: {caption}")
            _save(fig, path)
        return write

    def csv_writer(key):
        def write(path: Path) -> None:
            names, data = data_table(specs[key][3])
            np.savetxt(path, data, delimiter=",", header=",".join(names), comments="",
                       fmt="%.17g")
        return write

    def fig4(path: Path) -> None:
        fig = _figure(6.5, 6.0)
        ax = fig.add_subplot()
        draw_mechanism(ax, sol, [0, 90, 180, 270])
        ax.legend(fontsize=8, loc="lower right")
        ax.set_title("Fig. 4 (seed paper) counterpart: Hoeken's mechanism at crank angles 0, 90, "
                     "180, 270 deg\n(latest darkest) and the path of the coupler point P",
                     fontsize=9, loc="left")
        _save(fig, path)

    meta = {
        "reproduces": "worked example (Section 6) of the seed paper on recursive DeNOC "
                      "kinematics and inverse dynamics of a closed-loop four-bar: Hoeken's "
                      "straight-line linkage",
        "model": "bundled example 'hoeken' (linkdyn example hoeken): Table 1 data",
        "crank_speed_rpm": HOEKEN_RPM,
        "duration_s": period,
        "samples": HOEKEN_SAMPLES,
        "cut_joints": cut,
        "x_axis": "crank angle theta_1 = q_J1 (deg), 0..360, one sample per degree",
        "figures": {},
        "conventions": HOEKEN_CONVENTIONS,
        "files": {"results.csv": "every result column at the 361 samples (same columns as "
                                 "linkdyn analyze)",
                  "fig4_mechanism.png": "the mechanism at 4 crank angles and the coupler path"},
    }
    files = {"fig4_mechanism.png": fig4}
    for key, (fname, paper, caption, panels) in specs.items():
        files[fname] = fig_writer(key)
        files[f"{key}.csv"] = csv_writer(key)
        names, _ = data_table(panels)
        meta["figures"][key] = {
            "file": fname, "data": f"{key}.csv", "mirrors": f"{paper} of the seed paper",
            "caption": caption,
            "panels": [{"title": title, "unit": unit,
                        "series": [{"label": lbl, "column": col, "scale": scale}
                                   for lbl, col, scale in series]}
                       for title, unit, series in panels],
            "data_columns": names}
    meta["peaks"] = {"tau_J1_abs_max_Nm": float(np.max(np.abs(cols["tau_J1"]))),
                     "lambda_abs_max_N": float(np.max(np.hypot(cols["Fx_J4"], cols["Fy_J4"])))}
    files["reproduce.json"] = lambda p: p.write_text(json.dumps(meta, indent=2) + "\n")
    files["README.txt"] = lambda p: p.write_text(_readme(meta), encoding="utf-8")
    return sol, files


def _paper_figure(sol, x, panels, title):
    cols = sol.columns
    n = len(panels)
    fig = _figure(7.2, 2.7 * n + 0.7)
    axes = np.atleast_1d(fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0])
    for r, (ax, (ptitle, unit, series)) in enumerate(zip(axes, panels)):
        for k, (label, col, scale) in enumerate(series):
            _curve(ax, x, cols[col] * scale, lw=1.6, color=PALETTE[k], label=label)
        _style(ax, "crank angle θ1 (deg)" if r == n - 1 else "", unit, ptitle)
        ax.set_xlim(0, 360)
        ax.set_xticks(np.arange(0, 361, 45))
        ax.legend(fontsize=8, ncols=min(len(series), 4), loc="best")
    period = float(sol.t[-1] - sol.t[0])
    top = axes[0].secondary_xaxis("top", functions=(lambda a: a / 360.0 * period,
                                                    lambda s: s / period * 360.0))
    top.set_xlabel("t (s)", fontsize=8)
    top.tick_params(labelsize=8)
    import textwrap
    fig.suptitle(textwrap.fill(title, 100), fontsize=9.5)
    return fig


def _readme(meta: dict) -> str:
    lines = ["linkdyn reproduce hoeken",
             "========================", "",
             "Reproduces the " + meta["reproduces"] + ".",
             f"Model: {meta['model']}. Crank at {meta['crank_speed_rpm']:g} rpm, one turn "
             f"({meta['duration_s']:.6g} s), {meta['samples']} samples; loop cut at "
             f"{', '.join(meta['cut_joints'])} as in the paper. X axis of the figures: "
             f"{meta['x_axis']} (time on the top axis).", "", "Files", "-----"]
    for key, f in meta["figures"].items():
        lines.append(f"{f['file']}  ({f['mirrors']}): {f['caption']}.")
        for p in f["panels"]:
            cols = ", ".join(f"{s['label']} = {s['column']}"
                             + (" x 180/pi" if abs(s["scale"] - 1.0) > 1e-12 else "")
                             for s in p["series"])
            lines.append(f"    {p['title']} [{p['unit']}]: {cols}")
        lines.append(f"    plotted data: {f['data']}")
    for name, what in meta["files"].items():
        lines.append(f"{name}: {what}.")
    lines.append("reproduce.json: the same, machine-readable.")
    lines += ["", "Sign conventions", "----------------"]
    lines += [f"- {c}" for c in meta["conventions"]]
    lines += ["", f"Peak |tau_J1| = {meta['peaks']['tau_J1_abs_max_Nm']:.4g} N m; peak "
              f"|lambda| = {meta['peaks']['lambda_abs_max_N']:.4g} N.",
              "The paper gives these results as plots only (and reports that they match "
              "MSC ADAMS); compare the shapes and magnitudes with its Figs. 5-7.", ""]
    return "\n".join(lines)
