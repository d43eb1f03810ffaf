"""The backend that runs the stages, chosen in one place.

Every stage exists on two backends (docs/architecture.md, "Backends"): numpy's array passes
(the reference) and the compiled kernels (optional numba, :mod:`linkdyn.compiled`). The entry
points (``analyze``, ``kinematics.solve``, ``simulate``, the sweeps) call :func:`choose` once
with the user's ``backend=`` and the work to be done; the :class:`Backend` it returns is what
the stages then ask: :attr:`Backend.compiled` (which kernels run), and, for ``"auto"``,
:meth:`Backend.reconsider` as a run's work grows (``simulate``'s right-hand sides).

``"auto"`` compares two estimates of the wall time of the work, ``samples`` (per evaluation,
designs included) x ``bodies`` (moving) x ``evaluations`` (:class:`Work`):

- numpy: ``evaluations * bodies * (NUMPY_PASS + NUMPY_SAMPLE * samples)``: each stage is a
  Python loop over the bodies whose every pass costs Python's overhead plus its arithmetic
  over the samples;
- compiled: the start-up of the stages' kernels, none for a stage whose kernels this process
  has already run (:data:`IN_PROCESS`), :data:`LOAD` s each when numba's on-disk cache holds
  them (:func:`cached`), else their first compilation, :data:`COMPILE` s each; then
  ``evaluations * (COMPILED_CALL + bodies * COMPILED_SAMPLE * samples)``;

and takes the smaller (compiled on a tie). A run whose number of evaluations is not known in advance
(``simulate``) starts on numpy and switches once the numpy time spent would have paid for the
compiled start-up, by the estimate or by the clock (:meth:`Backend.reconsider`; at most about
twice the better choice's time). The
constants are measured (docs/performance.md, "How auto chooses"); results agree between the
backends to rounding whichever is chosen.

numba caches a kernel by its own file, and :mod:`linkdyn.compiled` drops every cache when a
source file changes; which stages the cache holds is recorded beside it, with the cache files
each was found with (:func:`mark_cached`), so deleting them makes the stage cold again. Before
the kernels of a stage compile cold, one line goes to the ``linkdyn`` logger (INFO), which the
command line prints on stderr.
"""

from __future__ import annotations

import json
import logging
import math
import os
from dataclasses import dataclass, field, replace

from . import compiled as _compiled
from .errors import InvalidValue, ModelError

BACKENDS = ("auto", "numpy", "compiled")
ENV = "LINKDYN_BACKEND"

# the stages that have compiled kernels, and what each runs (for the message before compiling)
STAGES = {"kinematics": "kinematics", "dynamics": "inverse dynamics",
          "reactions": "joint reactions", "sweep": "sweep (kinematics and dynamics fused)",
          "rhs": "simulate right-hand side"}
ANALYSIS = ("kinematics", "dynamics", "reactions")     # what analyze runs
SIMULATION = ("rhs",) + ANALYSIS                        # simulate: its right-hand side, outputs

# the cost model of "auto", s (measured on the 2-core development VM: docs/performance.md,
# "How auto chooses")
NUMPY_PASS = 5e-4        # one moving body's share of one numpy evaluation: Python's overhead
NUMPY_SAMPLE = 9e-7      # one moving body of one sample (design) in numpy's array passes
COMPILED_CALL = 1e-5     # one evaluation's call into the compiled code
COMPILED_SAMPLE = 1e-7   # one moving body of one sample in the compiled kernels
# each stage's kernels loaded from numba's cache, and compiled the first time (CPU time)
LOAD = {"kinematics": 0.5, "dynamics": 0.05, "reactions": 0.05, "sweep": 0.5, "rhs": 0.25}
COMPILE = {"kinematics": 80.0, "dynamics": 24.0, "reactions": 6.0, "sweep": 15.0, "rhs": 25.0}
# the stages whose kernels have run in this process (:func:`mark_cached`): loaded, no start-up
IN_PROCESS: set[str] = set()

log = logging.getLogger("linkdyn")


class MissingNumba(ModelError, ImportError):
    """``backend="compiled"`` without numba installed (exit status 2): how to install it."""


@dataclass(frozen=True)
class Work:
    """What a run will compute, for ``"auto"`` to weigh.

    Attributes
    ----------
    samples : int
        Samples of one evaluation, designs included (``analyze``: T x D; one right-hand side of
        ``simulate``: 1 + f, its batch of inverse dynamics).
    bodies : int
        Moving bodies.
    evaluations : int
        How many times the stages run (``analyze``: 1; ``simulate``: its right-hand sides).
    stages : tuple of str
        Which stages run (keys of :data:`STAGES`), each with kernels of its own to load or
        compile.
    """

    samples: int
    bodies: int
    evaluations: int = 1
    stages: tuple[str, ...] = ANALYSIS

    def numpy_seconds(self) -> float:
        """Estimated wall time on numpy, s."""
        return self.evaluations * self.bodies * (NUMPY_PASS + NUMPY_SAMPLE * self.samples)

    def compiled_seconds(self, cache: bool | None = None) -> float:
        """Estimated wall time on the compiled kernels, s, their start-up included (loaded if
        ``cache``, else compiled; default: none for a stage this process has run
        (:data:`IN_PROCESS`), else as :func:`cached` finds it)."""
        start = sum(0.0 if cache is None and s in IN_PROCESS
                    else LOAD[s] if (cached(s) if cache is None else cache) else COMPILE[s]
                    for s in self.stages)
        return start + self.evaluations * (COMPILED_CALL
                                           + self.bodies * COMPILED_SAMPLE * self.samples)


@dataclass(frozen=True)
class Backend:
    """A resolved backend: what the stages ask.

    Attributes
    ----------
    name : {'numpy', 'compiled'}
        Which kernels run.
    requested : {'auto', 'numpy', 'compiled'}
        What was asked (``"auto"`` may change its mind as the work grows: :meth:`reconsider`).
    work : Work or None
        The work it was chosen for.
    can_compile : bool
        Whether the compiled kernels could run it (numba installed, every joint kind known to
        them).
    """

    name: str
    requested: str = "auto"
    work: Work | None = field(default=None, compare=False)
    can_compile: bool = field(default=False, compare=False)

    @property
    def compiled(self) -> bool:
        """Whether the compiled kernels run."""
        return self.name == "compiled"

    def __str__(self) -> str:
        return self.name

    def pays_after(self, work: Work) -> float:
        """The evaluations of ``work`` (its ``evaluations`` ignored) after which ``"auto"``
        switches an open-ended run from numpy to compiled (:meth:`reconsider`): where numpy's
        estimated time has reached the compiled one, start-up included (``inf``: never, as
        for an explicit choice or a backend already compiled)."""
        if self.requested != "auto" or self.compiled or not self.can_compile:
            return math.inf
        one = replace(work, evaluations=1)
        start = one.compiled_seconds() - replace(one, stages=()).compiled_seconds()
        gain = one.numpy_seconds() - replace(one, stages=()).compiled_seconds()
        return math.ceil(start / gain) if gain > 0 else math.inf

    def start_up(self, work: Work) -> float:
        """The compiled start-up of ``work``'s stages, s (:meth:`Work.compiled_seconds` of no
        evaluation), against which an open-ended run weighs the time it has spent on numpy
        (``inf``: never switches, as for an explicit choice or a backend already compiled)."""
        if self.requested != "auto" or self.compiled or not self.can_compile:
            return math.inf
        return replace(work, evaluations=0).compiled_seconds()

    def reconsider(self, work: Work, spent: float = 0.0) -> Backend:
        """This backend for the work done so far (``"auto"`` only; explicit choices stay): an
        open-ended run switches to compiled once numpy's time for ``work`` would have paid for
        the compiled start-up, by the cost model, or once ``spent`` (the run's measured
        seconds on numpy) has reached that start-up (:meth:`start_up`), which bounds the run
        at about twice the better choice's time whatever its length and the machine's load.
        Never back to numpy."""
        if self.requested != "auto" or self.compiled or not self.can_compile:
            return self
        if spent >= self.start_up(work):
            chosen = Backend("compiled", "auto", work, True)
            announce(chosen)
            return chosen
        return _auto(work)


def choose(backend: str | Backend | None = None, work: Work | None = None, kinds=(), *,
           source: str = "", runs: bool = True) -> Backend:
    """The backend to run ``work`` on.

    Parameters
    ----------
    backend : {'auto', 'numpy', 'compiled'} or Backend, optional
        As given to ``analyze``, ``simulate``, the sweeps (case-insensitive); default the
        environment variable ``LINKDYN_BACKEND``, else ``"auto"``. A :class:`Backend` (already
        chosen by a caller) is returned as it is.
    work : Work, optional
        What will run; without it ``"auto"`` runs numpy.
    kinds : iterable of str
        The joint kinds of the model; a kind the kernels have no code for runs on numpy under
        ``"auto"`` and is refused under ``"compiled"``.
    source : str
        The model's file, for the error message.
    runs : bool
        Whether ``work`` runs now on the backend chosen (then a cold compilation is announced,
        :func:`announce`); ``False`` for a question only, such as a study's size check.

    Raises
    ------
    InvalidValue
        An unknown backend (field ``backend``, or ``LINKDYN_BACKEND`` when it came from
        there), or ``"compiled"`` for a joint kind without compiled code.
    MissingNumba
        ``"compiled"`` without numba: the message says how to install it.
    """
    if isinstance(backend, Backend):
        return backend
    if backend is not None and not isinstance(backend, str):
        raise TypeError(f"backend must be a str, not {type(backend).__name__}")
    given = backend or os.environ.get(ENV) or ""
    name = (given or "auto").lower()
    where = "backend" if backend else ENV
    if name not in BACKENDS:
        raise InvalidValue(f"unknown backend '{name}'", file=source, field=where,
                           fix=f"Use one of {', '.join(BACKENDS)}"
                               + ("" if backend else f", or unset {ENV}"))
    missing = _compiled.unsupported(kinds)
    if name == "compiled":
        if missing:
            raise InvalidValue(f"the compiled backend does not support {', '.join(missing)} "
                               "joints", file=source, field=where,
                               fix="Use the numpy or auto backend")
        if _compiled.numba is None:
            raise MissingNumba("the compiled backend needs numba", file=source, field=where,
                               fix="Install it with pip install 'linkdyn[fast]', or use the "
                                   "numpy or auto backend")
        chosen = Backend("compiled", "compiled", work, True)
        if runs:
            announce(chosen)
        return chosen
    can = not missing and _compiled.numba is not None
    if name == "numpy" or not can or work is None:
        return Backend("numpy", name, work, can)
    return _auto(work, runs)


def _auto(work: Work, runs: bool = True) -> Backend:
    """``"auto"``'s choice for ``work``: the smaller estimated time (announced if it
    ``runs``)."""
    fast = work.compiled_seconds() <= work.numpy_seconds()
    chosen = Backend("compiled" if fast else "numpy", "auto", work, True)
    if runs:
        announce(chosen)
    return chosen


# --- numba's on-disk cache: which stages it holds --------------------------------------------

_ROOT = os.path.dirname(os.path.abspath(__file__))
_RECORD = os.path.join(_ROOT, "__pycache__", _compiled.CACHE_RECORD)
_announced: set[str] = set()
_held: set[str] = set()   # stages this process found in the cache or recorded there


def _cache_files() -> list[str]:
    """numba's cache index files of the package's kernels, where numba writes them
    (:func:`linkdyn.compiled.cache_dirs`: beside the sources, or ``NUMBA_CACHE_DIR``'s folder)."""
    return sorted(os.path.join(d, f) for d in _compiled.cache_dirs() if os.path.isdir(d)
                  for f in os.listdir(d) if f.endswith(".nbi"))


def _record() -> dict[str, list[str]]:
    try:
        with open(_RECORD, encoding="utf-8") as fh:
            data = json.load(fh)
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def cached(stage: str) -> bool:
    """Whether numba's on-disk cache holds the compiled kernels of ``stage`` (a key of
    :data:`STAGES`): it was run compiled since the sources last changed, and the cache files
    present then are all still there. Once true, it stays true for the process, which then
    no longer reads the record and looks for the files at every call (about 1 ms: a sixth of
    an ``analyze`` of a few thousand samples)."""
    if stage in _held:
        return True
    files = _record().get(stage)
    if bool(files) and all(os.path.exists(f) for f in files):
        _held.add(stage)
    return stage in _held


def mark_cached(stage: str) -> None:
    """Record that ``stage``'s kernels have run compiled (so numba's cache now holds them),
    with the cache files present (nothing is written if the cache is not beside the package:
    a read-only installation), and that this process has them loaded (:data:`IN_PROCESS`)."""
    IN_PROCESS.add(stage)
    if cached(stage):
        return
    files = _cache_files()
    if not files:
        return
    data = _record()
    data[stage] = files
    tmp = f"{_RECORD}.{os.getpid()}"
    try:
        os.makedirs(os.path.dirname(_RECORD), exist_ok=True)
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(data, fh)
        os.replace(tmp, _RECORD)
        _held.add(stage)
    except OSError:
        pass


def announce(backend: Backend) -> None:
    """One line on the ``linkdyn`` logger (INFO) before the compiled kernels of the stages of
    ``backend.work`` not in numba's cache compile for the first time (once per stage and
    process)."""
    if not backend.compiled or backend.work is None:
        return
    cold = [s for s in backend.work.stages if s not in _announced and not cached(s)]
    if not cold:
        return
    _announced.update(cold)
    seconds = sum(COMPILE[s] for s in cold)
    log.info("compiling the %s kernels with numba (about %.0f s of CPU, once: cached on disk "
             "afterwards)", ", ".join(STAGES[s] for s in cold), seconds)



class _Echo(logging.Handler):
    """Passes the ``linkdyn`` logger's lines to a function (the command line's stderr)."""

    def __init__(self, echo):
        super().__init__(logging.INFO)
        self.echo = echo

    def emit(self, record):
        self.echo(f"linkdyn: {record.getMessage()}")


def show_progress(echo) -> None:
    """Print the ``linkdyn`` logger's INFO lines (the message before a cold compilation) with
    ``echo(line)``; called once by the command line, later calls replace the function."""
    for h in log.handlers:
        if isinstance(h, _Echo):
            h.echo = echo
            return
    log.addHandler(_Echo(echo))
    if log.level == logging.NOTSET or log.level > logging.INFO:
        log.setLevel(logging.INFO)
