"""Per-sample steps: every equation of the method written once, for both backends.

A *step* is a plain Python function over component tuples: a planar vector is ``(x, y)``, a
twist ``(w, vx, vy)``, a wrench ``(n, fx, fy)``, and each component is either an array over
samples and designs (numpy) or one float (inside a compiled sample loop). A step uses only
arithmetic, comparisons, the functions ``np.sqrt``, ``np.cos``, ``np.sin``, ``np.abs``, other
steps, and the two helpers below that differ by backend:

- :func:`select` (``np.where`` on arrays, a conditional expression on scalars),
- :func:`atan2` (``np.arctan2`` on arrays, straight-line code that vectorizes on scalars),
- :func:`settled` (whether an iteration's every step is below a tolerance: ``np.all`` on
  arrays, one comparison on scalars), so that an iteration stops once converged.

It returns a tuple (or one component). Under numpy the solvers call a step once per body on
whole arrays (the loops run over bodies, never over samples); the compiled backend registers
every step with numba (:func:`register`, done by :mod:`linkdyn.compiled`) and its kernels call
the same functions inside their sample loops, where numba compiles them for scalars and the
compiler inlines them. No equation is restated for the other backend.

A step that depends on a joint's kind is dispatched by :func:`by_kind`: the kind's own step is
chosen by its integer code (:data:`linkdyn.joints.CODES`), by Python under numpy and by a
branch the compiler hoists out of the sample loop under numba.
"""

from __future__ import annotations

import numpy as np

#: every step, in definition order (registered with numba on first compiled use)
STEPS: list = []


def step(fn=None, *, inline: bool = False):
    """Mark ``fn`` as a per-sample step (see the module docstring); returns ``fn`` itself.

    ``@step(inline=True)``: numba inlines the step into its callers before compiling them. For
    a large step called once per sample (a whole dyad), which the compiler would otherwise
    leave as a call, keeping the sample loop from being vectorized. A step defined after
    :func:`register` ran (its module imported later) is registered at once.
    """
    if fn is None:
        return lambda f: step(f, inline=inline)
    fn._step_inline = inline
    STEPS.append(fn)
    if _registered:
        _jitable(fn)
    return fn


def _jitable(fn) -> None:
    """Make the step ``fn`` callable from compiled code (compiled into its callers; inlined
    first if it was declared ``inline``)."""
    from numba.extending import register_jitable

    register_jitable(inline="always" if fn._step_inline else "never")(fn)


def select(cond, a, b):
    """``a`` where ``cond`` holds, else ``b`` (``np.where``; a conditional on scalars)."""
    return np.where(cond, a, b)


def atan2(y, x):
    """The angle of ``(x, y)``, rad in (-pi, pi] (``np.arctan2``; compiled: within 3 ulp)."""
    return np.arctan2(y, x)


def settled(dx, tol) -> bool:
    """Whether every ``|dx|`` is at most ``tol`` (False where ``dx`` is NaN): an iteration
    inside a step stops once its last step is below ``tol`` on every sample (compiled: on
    its one sample)."""
    return bool(np.all(np.abs(dx) <= tol))


def by_kind(steps: list):
    """One step ``f(code, *args)`` that calls ``steps[k](*args)`` for the ``(code, step)``
    pair whose code matches: a chain of comparisons, so that numba compiles every branch with
    the same argument types (all branches must return the same kind of tuple)."""
    (code, fn), rest = steps[0], steps[1:]
    if not rest:
        def call(kind, *args):
            return fn(*args)
    else:
        other = by_kind(rest)

        def call(kind, *args):
            if kind == code:
                return fn(*args)
            return other(kind, *args)
    call.__name__ = call.__qualname__ = f"by_kind_{fn.__name__}"
    return step(call)


_registered = False


def register(scalar_select, scalar_atan2) -> None:
    """Register every step with numba (compiled into its callers by the compiler), the
    scalar versions of :func:`select` and :func:`atan2`, and :func:`settled`; idempotent. Called by
    :mod:`linkdyn.compiled` when numba is installed."""
    global _registered
    if _registered:
        return
    from numba import types
    from numba.extending import overload

    for fn in STEPS:
        _jitable(fn)

    # select and atan2 are calls the compiler inlines (inlined by numba instead, inside a step
    # inlined in turn, their variables trip numba's IR checks: NumbaIRAssumptionWarning)
    @overload(select)
    def _select(cond, a, b):
        if isinstance(cond, types.Array) or isinstance(a, types.Array):
            return lambda cond, a, b: np.where(cond, a, b)
        return lambda cond, a, b: scalar_select(cond, a, b)

    @overload(atan2)
    def _atan2(y, x):
        if isinstance(y, types.Array) or isinstance(x, types.Array):
            return lambda y, x: np.arctan2(y, x)
        return lambda y, x: scalar_atan2(y, x)

    @overload(settled)
    def _settled(dx, tol):
        if isinstance(dx, types.Array):
            return lambda dx, tol: np.all(np.abs(dx) <= tol)
        return lambda dx, tol: abs(dx) <= tol

    _registered = True
