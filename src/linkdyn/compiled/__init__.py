"""Compiled per-sample kernels: the same recursions as the numpy solvers, fused per sample.

The numpy solvers (:mod:`linkdyn.kinematics`, :mod:`linkdyn.dynamics`) make one array pass per
operation over all samples; they are the reference. With the optional ``numba`` installed
(``pip install 'linkdyn[fast]'``), :func:`linkdyn.analyze` and :func:`linkdyn.kinematics.solve`
run these kernels instead: one compiled loop over the samples that walks the bodies of each
sample, with the same equations in the same order, writing the same component-first arrays.
The tests hold the two paths to agree to rounding.

The kernels read the numeric layout (:class:`linkdyn.kinematics.Layout`) itself: its
topology's integer arrays (computed once per layout) and views of its numbers with the design
axis last, ``D`` (1 for a single mechanism), and per-sample arrays shaped ``(..., D, T)``.

Choose the path with ``backend=`` (``"auto"``, ``"numpy"``, ``"compiled"``) or the environment
variable ``LINKDYN_BACKEND``; :mod:`linkdyn.backend` resolves it, ``"auto"`` by the work to be
done and by whether numba's on-disk cache (beside the modules) already holds the kernels: their
first compilation takes about three minutes of CPU (docs/performance.md, "The first
compilation"), loading them from the cache a fraction of a second. The helpers that take the
layout's view and that only kernels call are compiled without Python's and C's wrappers
(:func:`inner`), the kernels that Python calls with them (:func:`njit`).

The equations themselves are the steps of :mod:`linkdyn.steps` (registered here with numba),
which the numpy solvers call on whole arrays. numba caches each kernel on disk by its own file
only; since the steps live in other files, the caches are dropped whenever any source file of
the package changes (:func:`_drop_stale_caches`).
"""

from __future__ import annotations

import hashlib
import math
import os
import warnings

import numpy as np

from .. import joints as jk
from .. import steps

try:  # optional: the numpy path is complete without it
    import numba
except ImportError:  # pragma: no cover - depends on the environment
    numba = None
else:
    # numba's "internal pedantic check" of its IR after it inlines a step (``@step(inline=True)``,
    # friction's Newton step) names variables out of scope that the compiled code never reads:
    # a note for numba's developers, printed at a user's first compilation; not shown
    warnings.filterwarnings("ignore", category=numba.core.errors.NumbaIRAssumptionWarning)

# beside the stamp of the sources: which stages' kernels numba's cache holds (linkdyn.backend)
CACHE_RECORD = "numba-stages.json"

# joint kind codes inside the kernels: the registry's (linkdyn.joints.CODES; 0 the ground)
GROUND, REV, PRI = 0, jk.CODES["revolute"], jk.CODES["prismatic"]
# the kinds analyze runs compiled: every registered kind (both kernels call the kinds' steps)
CODES = dict(jk.CODES)


#: numba's options of every compiled function of the package: ``error_model="numpy"`` (a
#: division by zero gives inf or NaN as in numpy, no exception check per division)
OPTIONS = dict(nogil=True, error_model="numpy")
#: the options of a function that only compiled code calls: without the wrappers that let
#: Python (``no_cpython_wrapper``) or C (``no_cfunc_wrapper``) call it. A wrapper unboxes each
#: argument: for many arrays that is most of a small helper's compilation, for nothing,
#: since only the kernels call the helpers.
INNER = dict(OPTIONS, no_cpython_wrapper=True, no_cfunc_wrapper=True)


def njit(fn):
    """Compile ``fn`` in nopython mode, cached on disk (identity without numba): a kernel,
    callable from Python and from compiled code."""
    if numba is None:  # pragma: no cover
        return fn
    return numba.njit(cache=True, **OPTIONS)(fn)


def inner(fn):
    """Compile ``fn``, a helper that only compiled code calls, in nopython mode, cached on
    disk, without the wrappers that let Python or C call it (:data:`INNER`; called from
    Python it would crash the process): for the helpers that take the layout's view
    (identity without numba)."""
    if numba is None:  # pragma: no cover
        return fn
    return numba.njit(cache=True, **INNER)(fn)


def inline(fn):
    """A small helper of the kernels, compiled into its callers (no call, no reference counting
    of its array arguments per sample); callable from Python too. A helper that takes the
    layout's view is an :func:`inner` instead (inlined, it would be typed and lowered again
    at every call site)."""
    if numba is None:  # pragma: no cover
        return fn
    return numba.njit(inline="always", **OPTIONS)(fn)


def pack(view):
    """The layout's view (:data:`linkdyn.kinematics.layout.View`, a named tuple of arrays) as
    the kernels take it: one object, a numba ``StructRef`` with a field of the same name for
    each array (:class:`ViewRef`), which compiled code receives as one pointer (the named
    tuple would be about 800 arguments once numba flattens its arrays, at every call of every
    helper, which is most of the kernels' first compilation). Compiled code reads it by name
    as it read the tuple (``L.parent[i]``); Python reads its arrays by name too. The view
    itself without numba."""
    if numba is None:  # pragma: no cover
        return view
    ref = _packed(view)
    ref._view = view
    return ref


if numba is not None:
    from numba.core import cgutils
    from numba.core import types as _types
    from numba.experimental import structref as _structref
    from numba.experimental.jitclass.base import imp_dtor as _imp_dtor
    from numba.extending import intrinsic as _intrinsic

    @_structref.register
    class ViewType(_types.StructRef):
        """numba's type of :class:`ViewRef`: the view's fields, each its array's type."""

        def preprocess_fields(self, fields):
            return tuple((name, _types.unliteral(t)) for name, t in fields)

    class ViewRef(_structref.StructRefProxy):
        """The layout's view packed for the kernels (:func:`pack`); from Python, its arrays
        read by name (those of the named tuple it was packed from)."""

        def __getattr__(self, name):
            if name == "_view":
                raise AttributeError(name)
            return getattr(self._view, name)

    _structref.define_boxing(ViewType, ViewRef)

    @_intrinsic
    def _pack(typingctx, view):
        """A new :class:`ViewType` struct holding (a reference to) each array of the named
        tuple ``view``, field by field under the tuple's names."""
        inst = ViewType(list(zip(view.fields, view.types)))

        def codegen(context, builder, sig, args):
            # structref.new's allocation, then each field set from the tuple
            data_type = inst.get_data_type()
            alloc_type = context.data_model_manager[data_type].get_value_type()
            meminfo = context.nrt.meminfo_alloc_dtor(
                builder, context.get_constant(_types.uintp, context.get_abi_sizeof(alloc_type)),
                _imp_dtor(context, builder.module, inst))
            ptr = builder.bitcast(context.nrt.meminfo_data(builder, meminfo),
                                  alloc_type.as_pointer())
            builder.store(cgutils.get_null_value(alloc_type), ptr)
            data = cgutils.create_struct_proxy(data_type)(context, builder, ref=ptr)
            for k, (name, ty) in enumerate(zip(view.fields, view.types)):
                value = builder.extract_value(args[0], k)
                context.nrt.incref(builder, ty, value)
                setattr(data, name, value)
            out = context.make_helper(builder, inst)
            out.meminfo = meminfo
            return out._getvalue()
        return inst(view), codegen

    @numba.njit(cache=True, **OPTIONS)
    def _packed(view):
        """:func:`pack`'s struct, made by compiled code (cached on disk)."""
        return _pack(view)


_FROM_PYTHON: dict = {}


def from_python(fn):
    """``fn``, an :func:`inner` helper, compiled once more with the wrappers, so that Python
    can call it: for the benchmarks that time one helper of a kernel alone (the same code; the
    kernels call ``fn`` itself)."""
    if numba is None:  # pragma: no cover
        return fn
    if fn not in _FROM_PYTHON:
        _FROM_PYTHON[fn] = numba.njit(**OPTIONS)(fn.py_func)
    return _FROM_PYTHON[fn]


# atan u = u + u^3 S(u^2) for |u| <= tan(pi/8): the coefficients of S, lowest power first, a
# least-squares fit of degree 10 to (atan u - u) / u^3 at 4000 Chebyshev nodes of u^2
ATAN_S = (-0.3333333333333323, 0.19999999999954723, -0.14285714279535322, 0.11111110719635554,
          -0.0909089521306692, 0.07692004797293968, -0.06662380954213483, 0.058420795938553025,
          -0.050111270743186685, 0.03730753548029459, -0.017041827341099033)
TAN_PI_8 = 0.41421356237309503
PI_LO = math.sin(math.pi)   # pi - math.pi, the bits of pi below the double's


@inline
def arctan2(y, x):
    """``math.atan2(y, x)`` in straight-line code, so that a sample loop computing it compiles
    to vector instructions (a call into the C library keeps a loop scalar).

    Within 3 ulp of ``math.atan2``, with its signs of zero and its NaN; only ``x`` and ``y``
    both infinite give NaN instead of an odd multiple of pi/4. The ratio t = min/max of |y|,
    |x| in [0, 1] reduces, beyond tan(pi/8), to u = (t - 1) / (t + 1) with
    atan t = pi/4 + atan u; the octant then follows from which was larger and the signs.
    """
    ax, ay = abs(x), abs(y)
    swap = ay > ax
    top, low = (ay, ax) if swap else (ax, ay)
    t = low / top if top != 0 else low
    far = t > TAN_PI_8
    u = (t - 1.0) / (t + 1.0) if far else t
    z = u * u
    p = ATAN_S[10]
    for j in range(9, -1, -1):   # Horner, unrolled by the compiler
        p = p * z + ATAN_S[j]
    a = u + u * z * p
    # atan t, then the angle of (|x|, |y|), then of (x, |y|); the sign of y last
    a = math.pi / 4 + (a + PI_LO / 4) if far else a
    a = (math.pi / 2 - a) + PI_LO / 2 if swap else a
    a = (math.pi - a) + PI_LO if math.copysign(1.0, x) < 0 else a
    return math.copysign(a, y)


@inline
def vector_views(x, i, d, ks):
    """Entity i's planar vector of ``x`` (n, 2, D, T) over the samples ``ks`` of design d: its
    components x, y as 1-D views. The kernels index such views inside their sample loops,
    without the multi-dimensional address arithmetic of every access."""
    return x[i, 0, d, ks], x[i, 1, d, ks]


@inline
def screw_views(x, i, d, ks):
    """Entity i's twist or wrench of ``x`` (n, 3, D, T) over the samples ``ks`` of design d:
    its components [w, vx, vy] or [M, Fx, Fy] as 1-D views (see :func:`vector_views`)."""
    return x[i, 0, d, ks], x[i, 1, d, ks], x[i, 2, d, ks]


@inline
def choose(cond, a, b):
    """:func:`linkdyn.steps.select` on scalars."""
    return a if cond else b


def _source_dirs() -> list[str]:
    """The package's folders that hold Python sources (each one a cache folder for numba)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return sorted(d for d, _, fs in os.walk(root) if any(f.endswith(".py") for f in fs))


def cache_dirs(every: bool = False) -> list[str]:
    """The folders where numba keeps the package's kernels, one per source folder: the one its
    own cache locators choose for that folder's files (``NUMBA_CACHE_DIR``'s mirror of the folder
    when that is set, else the ``__pycache__`` beside the sources, else the user's cache folder).
    With ``every``, each source folder's every candidate (a cache written under one setting is
    still there under another). Empty without numba."""
    if numba is None:  # pragma: no cover
        return []
    from numba.core import caching, config

    # numba's order of locators (numba.core.caching._CacheImpl), the ones a source file can use
    classes = [caching.InTreeCacheLocator, caching.UserWideCacheLocator]
    if config.CACHE_DIR:
        classes.insert(0, caching.UserProvidedCacheLocator)
    out = []
    for d in _source_dirs():
        source = os.path.join(d, next(f for f in sorted(os.listdir(d)) if f.endswith(".py")))
        if every:
            out += [cls(cache_dirs, source).get_cache_path() for cls in classes]
            continue
        for cls in classes:
            locator = cls.from_function(cache_dirs, source)
            if locator is not None:
                out.append(locator.get_cache_path())
                break
    return sorted(set(out))


def _drop_stale_caches() -> None:
    """Delete the kernels' on-disk caches (in every folder numba may have written them,
    :func:`cache_dirs`) when any source file of the package has changed since they were
    written (numba checks only each kernel's own file, not the steps it calls), and the record
    of which stages they hold (:data:`CACHE_RECORD`). The package's files' sizes and
    modification times are the stamp."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    files = sorted(os.path.join(d, f) for d in _source_dirs() for f in os.listdir(d)
                   if f.endswith(".py"))
    stamp = hashlib.sha256("\n".join(
        f"{os.path.relpath(f, root)} {os.stat(f).st_size} {os.stat(f).st_mtime_ns}"
        for f in files).encode()).hexdigest()
    path = os.path.join(root, "__pycache__", "numba-sources.stamp")
    try:
        with open(path) as fh:
            if fh.read() == stamp:
                return
    except OSError:
        pass
    try:
        for d in cache_dirs(every=True):
            for f in os.listdir(d) if os.path.isdir(d) else ():
                if f.endswith((".nbi", ".nbc")):
                    os.remove(os.path.join(d, f))
        record = os.path.join(root, "__pycache__", CACHE_RECORD)
        if os.path.exists(record):
            os.remove(record)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w") as fh:
            fh.write(stamp)
    except OSError:   # a read-only installation: numba then caches elsewhere or not at all
        pass


if numba is not None:   # the steps compile into the kernels that call them
    steps.register(choose, arctan2)
    _drop_stale_caches()


def unsupported(kinds) -> list[str]:
    """The joint kinds among ``kinds`` that the kernels have no code for (not in :data:`CODES`:
    none of the registered kinds)."""
    return sorted({k for k in kinds if k not in CODES})


@inline
def _factor2(A, nb, perm, rel):
    """:func:`factor` for m = 2, a sample at a time: the same operations in the same order."""
    for k in range(nb):
        a00, a01, a10, a11 = A[0, 0, k], A[0, 1, k], A[1, 0, k], A[1, 1, k]
        top = max(max(max(max(0.0, abs(a00)), abs(a01)), abs(a10)), abs(a11))
        finite = a00 == a00 and a01 == a01 and a10 == a10 and a11 == a11
        perm[0, k], perm[1, k] = 0, 1
        if abs(a10) > abs(a00):   # the second row swaps up
            a00, a01, a10, a11 = a10, a11, a00, a01
            perm[0, k], perm[1, k] = 1, 0
        # l = a10 / a00, u11 = a11 - l a01; rel = the smaller pivot over the largest |K_ij|
        f = a10 * (1.0 / a00)
        u11 = a11 - f * a01
        low = math.inf if finite else math.nan
        for piv in (abs(a00), abs(u11)):
            low = piv if piv != piv or piv < low else low
        A[0, 0, k], A[0, 1, k], A[1, 0, k], A[1, 1, k] = a00, a01, f, u11
        rel[k] = low / (top if top > 0 else 1.0)


@inline
def _substitute2(A, perm, rel, nb, b, x, tol):
    """:func:`substitute` for m = 2, a sample at a time: the same operations in the same
    order."""
    for k in range(nb):
        y0, y1 = b[perm[0, k], k], b[perm[1, k], k]
        x1 = (y1 - A[1, 0, k] * y0) / A[1, 1, k]
        x0 = (y0 - A[0, 1, k] * x1) / A[0, 0, k]
        if not rel[k] > tol:
            x0, x1 = math.nan, math.nan
        x[0, k], x[1, k] = x0, x1


@njit
def factor(A, m, nb, perm, rel):
    """LU-factor the m x m matrices of a block of samples in place: ``P K = L U``.

    ``A`` (m, >= m, block): ``K`` in the first m columns for each sample k < ``nb``; on return
    U on and above the diagonal and the multipliers of L below it. Partial pivoting under the
    rules of :func:`linkdyn.planar.solve_small`: a row swaps up where its entry is strictly
    larger; ``perm`` (m, block) records the row order. ``rel`` (block,): the smallest pivot
    over the largest ``|K_ij|`` (NaN if ``K`` holds a NaN). A row whose multiplier is zero is
    left as it is when ``K`` is finite (the long chains' sparse ``J_dep``); with an infinite or
    NaN entry every row is updated, so that they spread as in ``solve_small``.
    """
    if m == 2:   # one loop, the same operations per sample (a single loop's J_dep)
        _factor2(A, nb, perm, rel)
        return
    scale = np.empty(nb)
    finite_k = np.empty(nb, np.bool_)
    for k in range(nb):
        top, finite = 0.0, True
        for i in range(m):
            perm[i, k] = i
            for j in range(m):
                top = max(top, abs(A[i, j, k]))
                finite = finite and A[i, j, k] == A[i, j, k]
        scale[k] = top if top > 0 else 1.0
        rel[k] = math.inf if finite else math.nan
        finite_k[k] = finite and top < math.inf
    for p in range(m):
        # partial pivoting: rows swap whole, with the multipliers already stored in them
        for i in range(p + 1, m):
            for k in range(nb):
                if abs(A[i, p, k]) > abs(A[p, p, k]):
                    for j in range(m):
                        A[p, j, k], A[i, j, k] = A[i, j, k], A[p, j, k]
                    perm[p, k], perm[i, k] = perm[i, k], perm[p, k]
        for k in range(nb):   # the smallest pivot; a NaN pivot makes it NaN
            a = abs(A[p, p, k])
            rel[k] = a if a != a or a < rel[k] else rel[k]
        # eliminate column p below the pivot: row_i -= l_ip row_p, l_ip kept in its place
        for i in range(p + 1, m):
            for k in range(nb):
                f = A[i, p, k] * (1.0 / A[p, p, k])
                A[i, p, k] = f
                if f != 0.0 or not finite_k[k]:
                    for j in range(p + 1, m):
                        A[i, j, k] -= f * A[p, j, k]
    for k in range(nb):
        rel[k] /= scale[k]


@njit
def substitute(A, perm, rel, m, nb, b, x, tol):
    """Solve ``K x = b`` for a block of samples from :func:`factor`'s ``A``, ``perm``, ``rel``:
    ``L y = P b``, then ``U x = y``. ``b``, ``x`` (m, block); ``x`` is NaN where ``rel`` is
    not above ``tol``."""
    if m == 2:
        _substitute2(A, perm, rel, nb, b, x, tol)
        return
    for i in range(m):
        for k in range(nb):
            x[i, k] = b[perm[i, k], k]
    for p in range(m):   # y_i -= l_ip y_p
        for i in range(p + 1, m):
            for k in range(nb):
                x[i, k] -= A[i, p, k] * x[p, k]
    for p in range(m - 1, -1, -1):   # x_p = (y_p - sum_j u_pj x_j) / u_pp
        for k in range(nb):
            acc = x[p, k]
            for j in range(p + 1, m):
                acc -= A[p, j, k] * x[j, k]
            x[p, k] = acc / A[p, p, k]
    for k in range(nb):
        if not rel[k] > tol:
            for p in range(m):
                x[p, k] = math.nan


@njit
def eliminate(A, m, nb, x, rel, tol):
    """Solve the m x m systems of a block of samples at once: ``A`` (m, m + 1, block) holds
    the augmented matrices ``[K | b]`` (overwritten); ``x`` (m, block) and the relative pivot
    ``rel`` (block,) as in :func:`factor` and :func:`substitute`."""
    perm = np.empty((m, nb), np.int64)
    factor(A, m, nb, perm, rel)
    # b copied out contiguous: substitute then compiles once for its C-contiguous callers
    substitute(A, perm, rel, m, nb, np.ascontiguousarray(A[:, m, :]), x, tol)
