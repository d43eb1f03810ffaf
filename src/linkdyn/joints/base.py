"""The joint-kind protocol: everything the solvers ask of a joint, in one class.

A joint joins body ``a`` (first, ``connect[0]``) and body ``b`` (second, ``connect[1]``). As a
*tree joint* it places its child (body i, ``s = +1`` if the child is the joint's second body,
``-1`` if the first) from its parent by one coordinate ``q``; as a *cut joint* it contributes
:attr:`JointKind.rows` loop-closure rows. A kind that cannot be a tree joint (``tree = False``,
e.g. a pin in a slot, which leaves two relative freedoms) is always cut.

Each kind writes its equations once, as static steps (:mod:`linkdyn.steps`) that both backends
call. For a tree joint (eqs. 1-3 of the seed paper, planar): ``place`` (the child's pose from
the parent's and ``q``), ``motion`` (the propagation vector ``p_i``), ``plus_motion`` and
``plus_motion_rate`` (``x + p_i rate``, ``x + pd_i rate``). For a cut joint at the second body's
point P, with ``x`` the relative twist of b to a at P: ``residual`` (the position closure rows),
``selected`` (``S x``), ``selected_rate`` (``(dS/dt) x``), ``wrench`` (the constraint wrench
on b at P, ``S^T lam`` and any part that does no work) and ``coordinate`` (the joint's
coordinate, rate and acceleration from its bodies' motion: a cut joint's ``q`` is an output,
not an unknown).

Every cut step (protocol version 4) takes first the cut's own numbers ``nums`` and its frame
``f``: ``nums`` is the tuple of the kind's scalar numbers (shape ``()``, in its declaration
order, :attr:`JointKind.scalars`) padded with zeros to :data:`WIDTH`; ``f = (e_a, d, e_b,
t)`` holds the axis ``e_a`` (the kind's ``axis`` fixed in a, global; ``(1, 0)`` turned with a
for a kind without one), ``d = r_Pb - r_Pa``, the second body's cut point from the first's
(m), ``e_b``, the second body's x axis (global), and ``t``, the contact's parameter of a
higher pair (a cam's: the cam angle where the follower touches), found once per frame by the
kind's ``locate`` step where the frame is made (:func:`linkdyn.kinematics.recursion.cut_frame`)
and read by every other cut step; 0 for a kind without a contact to find (:func:`frame`). A step that needs the frame's motion
takes ``fd = (w_a, d', w_b)``: ``e_a`` turns at a's angular velocity ``w_a``, ``e_b`` at b's
``w_b``, ``d'`` is the rate of ``d`` (m/s). So a kind may depend on both cut points (a gear's
line of centres), on both bodies' angles (a flat-faced cam follower's face) and on any number
of its own, with no edit of the solvers. :meth:`JointKind.motion_vector`,
:meth:`JointKind.cut_rows` and :meth:`JointKind.selection` give them as arrays.

Arrays are component-first (see :mod:`linkdyn.planar`): a planar vector is ``(2, ...)``, a
twist ``[w, vx, vy]`` or wrench ``[n, fx, fy]`` is ``(3, ...)``; ``e_a`` is the joint's axis,
fixed in its first body, in global components. A kind module defines one subclass and one
instance ``KIND``; :mod:`linkdyn.joints` registers it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..planar import dot, normal
from ..steps import step


@dataclass(frozen=True)
class Number:
    """One number a joint kind takes per joint, as the model file, the model, the layout, the
    kernels' view of it and the design studies carry it.

    Attributes
    ----------
    name : str
        Its model-file key, its name in :attr:`linkdyn.model.Joint.numbers`, and (``cut_``
        before it for a cut joint's) its array in the numeric layout and its kernels' view.
    shape : tuple
        ``()`` a number, ``(2,)`` a vector ``[x, y]``.
    unit : str
        ``'angle'``, ``'length'`` or ``'pressure'`` (converted from the file's ``[units]``:
        a pressure in N per its length unit squared, N/mm^2 = MPa in a mm file), else ``''``
        (written as it is, SI).
    default : float or tuple
        Its value where the file does not give it.
    direction : bool
        A direction: made a unit vector on reading; zero is refused.
    design : bool
        Whether a design parameter may vary it (a sweep's designs differ in it); if not, every
        design of a batch must share it.
    doc : str
        What it is, for messages and the model format's reference.
    choices : tuple[str, ...]
        For a number the file gives by name (a cam's motion law): the names of the values 0,
        1, 2, ...; the reader takes a name and the writer writes it back. Empty: a number.
    derived : bool
        Computed from the model by the kind (a coupling's signs and direction, from the joints
        it couples), not read from the model file nor written to it.
    """

    name: str
    shape: tuple = ()
    unit: str = ""
    default: Any = 0.0
    direction: bool = False
    design: bool = True
    doc: str = ""
    choices: tuple = ()
    derived: bool = False

    def value(self, x=None) -> np.ndarray | float:
        """``x`` (SI) as this number's value, the default where None: a float, or a float
        array of :attr:`shape`."""
        x = self.default if x is None else x
        return float(x) if not self.shape else np.array(x, float).reshape(self.shape)


#: the length of a cut's numbers tuple ``nums``, as every cut step takes it (the kind's scalar
#: numbers, padded with zeros, or the numbers a kind derives from them: a cam's nine the most)
WIDTH = 9


@step
def frame(r_pa, r_pb, axes):
    """A cut's frame ``(e_a, d, e_b, t)`` as the cut steps take it: its axis ``e_a``
    (global), ``d = r_Pb - r_Pa``, the second body's cut point from the first's (m), the
    second body's x axis ``e_b`` (global) and the contact's parameter ``t`` (the kind's
    ``locate``; 0 for a kind without one), from the cut points and ``axes = (e_ax, e_ay, e_bx,
    e_by, t)`` (:func:`linkdyn.kinematics.recursion.cut_frame`)."""
    return ((axes[0], axes[1]), (r_pb[0] - r_pa[0], r_pb[1] - r_pa[1]), (axes[2], axes[3]),
            axes[4])


@step
def no_contact(nums, f):
    """The ``locate`` of a kind without a contact to find (every lower pair, a gear's): 0."""
    return 0.0


#: a slider's or a slot's axis: a unit direction fixed in the joint's first body, in its frame
AXIS = Number("axis", (2,), "", (1.0, 0.0), direction=True,
              doc="sliding direction")
#: a slider's fixed angle of the second body's frame to the first's
ANGLE = Number("angle", (), "angle", 0.0,
               doc="fixed angle of the second body's frame relative to the first's")


class JointKind:
    """Base class of the joint kinds; the attributes describe the kind to the rest of the code.

    Attributes
    ----------
    name : str
        The model file's ``type``.
    freedoms : int
        Relative freedoms the joint leaves its two bodies (of the plane's three).
    rows : int
        Loop-closure rows when cut: ``3 - freedoms``; Grübler–Kutzbach counts them.
    tree : bool
        Whether it can be a tree joint (one coordinate places the child); if not, it is always cut.
    angular : bool
        Its coordinate ``q`` is an angle (rad; else a length, m).
    numbers : tuple[Number, ...]
        The numbers it takes per joint (its model-file keys beyond ``name``, ``type``,
        ``connect``), in the order :class:`~linkdyn.model.Joint` takes them positionally.
    keys : tuple[str, ...]
        Their names (read-only).
    row_units : tuple[str, ...]
        ``'rad'`` or ``'m'`` for each cut row (the closure residual is scaled by them).
    reaction : tuple[str, ...]
        Reaction columns it reports, from ``('Fx', 'Fy', 'M')``.
    multipliers : tuple[tuple[str, str], ...]
        ``(label, unit)`` of each cut row's multiplier, in row order.
    effort : str or None
        Prefix of a driver's effort column (``'tau'`` N m, ``'force'`` N); None: not drivable.
    dyad : str or None
        Its letter in the closed-form dyads of :mod:`linkdyn.kinematics.dyads` (``'R'``,
        ``'P'``); None: loops it closes use Newton's method.
    periodic : bool
        Whether its closure rows are unchanged by a whole turn of either body (a lower pair's
        are; a gear's are not: turning one gear a whole turn moves the other by the ratio).
        If not, the assembly keeps the dependent angles Newton's method found (no whole
        turns moved to bring them near the guess) and ``simulate`` integrates the free
        angles with their whole turns (F12 off).
    cut_rank : int
        Which joints of a loop the topology cuts first: the highest rank (0 a revolute joint,
        1 a sliding one, which leaves loops that close in closed form).
    one_sided : bool
        Whether its contact can only push (a cam's): a multiplier below zero is where the
        bodies would part, which the run's summary reports (``contact`` in ``summary.json``).
    column : str or None
        Prefix of a results column that carries the cut's multiplier (its first row), named
        ``<column>_<joint>`` in the unit of :attr:`multipliers` (a coupling's ``torque``, a
        generalized effort); None: the multipliers are reported as the reaction only.
    couples : bool
        Whether the model file names the joints it couples (``joints = ["J1", "J2"]``) instead
        of ``connect``: its bodies, points and derived numbers come from them (a coupling,
        :func:`linkdyn.joints.coupling.couple`).
    """

    name = ""
    freedoms = 1
    tree = True
    angular = True
    numbers: tuple[Number, ...] = ()
    row_units: tuple[str, ...] = ()
    reaction: tuple[str, ...] = ("Fx", "Fy")
    multipliers: tuple[tuple[str, str], ...] = ()
    effort: str | None = None
    dyad: str | None = None
    periodic = True
    one_sided = False
    column: str | None = None
    couples = False

    @property
    def cut_rank(self) -> int:
        return 0 if self.angular else 1

    @property
    def rows(self) -> int:
        return 3 - self.freedoms

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(x.name for x in self.numbers)

    @property
    def scalars(self) -> tuple[str, ...]:
        """The names of its scalar numbers (shape ``()``), in order: the entries of the
        ``nums`` tuple its cut steps take (padded with zeros to :data:`WIDTH`)."""
        out = tuple(x.name for x in self.numbers if not x.shape)
        if len(out) > WIDTH:
            raise TypeError(f"joint kind {self.name!r} has more than {WIDTH} scalar numbers")
        return out

    def own(self, numbers: dict, zero=0.0) -> tuple:
        """The tuple ``nums`` of its cut steps from a joint's ``numbers`` (name -> value; a
        value may be an array with a design axis): its :attr:`scalars`, padded with ``zero``
        to :data:`WIDTH`. A kind may override it to give its steps numbers derived from its
        own (WIDTH of them, each ``zero`` plus a number where constant; a number no design
        may vary stays a float under numpy, so a step may branch on it)."""
        own = tuple(numbers[k] for k in self.scalars)
        return own + (zero,) * (WIDTH - len(own))

    def tree_numbers(self, values: dict, sign: int) -> dict:
        """The joint's numbers ``values`` (name -> SI value, as the model holds them) as its
        tree row of the layout holds them, for a tree joint whose child is its second body
        (``sign = +1``) or its first (``-1``): by default the same."""
        return values

    def __repr__(self) -> str:
        return f"<joint kind {self.name!r}>"

    # --- checks of a joint the reader and the assembly ask (a kind without them: none) ------
    def refuse(self, numbers: dict) -> str | None:
        """Why a joint's numbers (name -> SI value, as read) are not valid for the kind, for
        the reader's message (exit 2); None: they are."""
        return None

    #: ``locate(nums, f) -> t``: a higher pair's contact parameter at the frame ``f`` (whose
    #: ``t`` is a start guess, NaN: none, as one sample's float), the one place it is searched
    #: for (a cam's Newton iterations); the other cut steps read it as ``f[3]``. None: no
    #: contact to find (``t`` = 0).
    locate = None

    #: ``fit(nums, f) -> (misfit, wanted, what)``: for a kind whose rows hold less than its
    #: geometry needs (a gear's centre distance, held by the tree, not by its row), how far
    #: the assembled frame is from it (m, the batch shape), the value wanted (m) and what is
    #: measured; the assembly refuses a misfit (exit 3 naming the joint). None: no such need.
    fit = None

    # --- the kind's steps (linkdyn.steps: static, on component tuples, for both backends) ---
    # A kind defines those that apply as static methods decorated with ``@step``; the solvers
    # call them through the dispatchers of :mod:`linkdyn.joints` (by the kind's code), or
    # through the array methods below. Vectors are ``(x, y)``, twists and wrenches 3-tuples;
    # cut rows are padded to three (the first :attr:`rows` count).
    #
    #   place(s, q, turn, angle, axis_p, phi_p, cos_p, sin_p, r_joint) -> phi, cos, sin, r, e
    #       the child's pose from its parent's and q (tree joint); turn: (cos, sin) of s q for
    #       an angular kind (else unused, (1, 0)); e: the global axis, or (0, 0)
    #   motion(s, e) -> p                             p_i of eq. (3)
    #   plus_motion(s, e, x, rate) -> x + p_i rate
    #   plus_motion_rate(s, e, w_axis, x, rate) -> x + pd_i rate (w_axis: angular velocity
    #       of the body carrying the axis)
    # The cut steps (protocol 4) take the cut's numbers ``nums`` (WIDTH-tuple) and frame
    # ``f = (e_a, d, e_b, t)`` first (module docstring); ``fd = (w_a, d', w_b)`` is its rate:
    #   residual(nums, f, phi_a, phi_b) -> rows   position closure (cut joint)
    #   selected(nums, f, x) -> S x                   x: relative twist of b to a at the cut
    #   selected_rate(nums, f, fd, x) -> (dS/dt) x
    #   wrench(nums, f, lam) -> on the second body about the cut point: S^T lam, plus any
    #       force that does no work while the tree holds the frame (a gear's radial force)
    #   coordinate(nums, f, a, b, dd, dd2) -> q, qd, qdd   a cut joint's coordinate, from the
    #       bodies' (phi, w, al) and the rates d', d'' of d
    place = motion = plus_motion = plus_motion_rate = None
    residual = selected = selected_rate = wrench = coordinate = None

    # --- array forms (component-first arrays), for the design metrics and the dense reference
    def motion_vector(self, s, e, ndim):
        """Joint-motion propagation vector ``p_i`` (3, ...) of eq. (3); a constant one is shaped
        ``(3, 1, ...)`` to broadcast over ``ndim`` batch axes. ``e``: global axis or None."""
        self._tree_only()
        p = _stack(self.motion(s, (0.0, 0.0) if e is None else e))
        return p.reshape((3,) + (1,) * ndim) if p.ndim == 1 else p

    def cut_rows(self, nums, f, x):
        """Cut-row selection ``S x`` (rows, ...) of a relative twist or twist rate ``x`` (3, ...)
        of the second body to the first at the cut point (``nums``, ``f``: the cut's numbers
        and frame, as the cut steps take them)."""
        return _stack(self.selected(nums, f, x)[:self.rows], x[0])

    # --- explicit matrices, for the dense reference -----------------------------------------
    def selection(self, nums, e_a, d, e_b) -> np.ndarray:
        """The cut-row selection matrix ``S`` (rows, 3) at one sample: ``nums`` the cut's
        numbers (:meth:`own`), ``e_a`` (2,) its global axis, ``d`` (2,) the second body's cut
        point from the first's, ``e_b`` (2,) the second body's x axis; the cut rows of the
        identity's columns."""
        f = self.frame_at(nums, e_a, d, e_b)
        return np.asarray(self.cut_rows(nums, f, np.eye(3))).reshape(self.rows, 3)

    def contact(self, nums, e_a, d, e_b, lam) -> np.ndarray:
        """The constraint wrench (3,) ``[n, fx, fy]`` of the multipliers ``lam`` (rows,) on the
        second body about its cut point at one sample (the kind's ``wrench``; ``S^T lam`` for
        a lower pair), for the dense reference."""
        f = self.frame_at(nums, e_a, d, e_b)
        lam = tuple(float(x) for x in lam) + (0.0,) * (3 - len(lam))
        return np.array([float(x) for x in self.wrench(nums, f, lam)])

    def frame_at(self, nums, e_a, d, e_b) -> tuple:
        """The frame ``(e_a, d, e_b, t)`` of one sample (each vector (2,)), its contact's
        parameter ``t`` found by the kind's ``locate``."""
        f = (np.asarray(e_a, float), np.asarray(d, float), np.asarray(e_b, float), np.nan)
        return f[:3] + (0.0 if self.locate is None else float(self.locate(nums, f)),)

    def _tree_only(self):
        if self.place is None:
            raise NotImplementedError(f"a {self.name} joint cannot be a tree joint")


def _stack(parts, *like) -> np.ndarray:
    """A component-first array (k, ...) from a step's tuple of components, broadcast with the
    arrays ``like`` too (a constant step result takes the batch shape of its inputs)."""
    shape = np.broadcast_shapes(*(np.shape(x) for x in tuple(parts) + like))
    out = np.empty((len(parts),) + shape)
    for k, x in enumerate(parts):
        out[k] = x
    return out


@step
def line_motion(e_a, w_a, al_a, d, dd, dd2):
    """Coordinate, rate and acceleration of a point sliding on a line fixed in body a.

    ``s = d . e`` with ``d`` the second body's point from the first's and ``e`` turning at
    ``w_a``: ``s' = d' . e + d . e'``, ``s'' = d'' . e + 2 d' . e' + d . e''`` with
    ``e' = w_a perp(e)``, ``e'' = al_a perp(e) - w_a^2 e``.
    """
    n = normal(e_a)
    ed = (w_a * n[0], w_a * n[1])
    edd = (al_a * n[0] - w_a ** 2 * e_a[0], al_a * n[1] - w_a ** 2 * e_a[1])
    return dot(d, e_a), dot(dd, e_a) + dot(d, ed), dot(dd2, e_a) + 2 * dot(dd, ed) + dot(d, edd)
