"""Compiled kernels that cost nothing on small inputs: plain Python below a size, numba above.

A *kernel* is a function over numpy arrays and scalars written in the subset of Python that
numba compiles (the scanner of ``nc.fastparse``, the look-ahead loops of ``plan._kernels``, the
CSV row writer of ``report.csvformat``, the nearest-point searches of ``gap.nearest`` and
``gap.align``, the servo integrator of ``gap.truth.servo``). :func:`njit` (a stand-in for ``numba.njit``) wraps it
in a :class:`Kernel` that runs either the function itself, as plain Python, or numba's
compiled version of it:

* numba's fixed cost is large against a short program: importing it takes about 0.25 s, and
  loading its first cached kernel another 0.35-0.5 s (its lowering registries, which import
  scipy.linalg), while the whole run of a 10-line program takes a few milliseconds of kernel
  work. A call whose input is smaller than the kernel's ``python_below`` (the length of its
  first array or ``bytes`` argument) therefore runs as plain Python and numba is never
  imported;
* a larger call runs compiled (``cache=True``: the first time after installing, numba compiles
  and caches the kernels, announced once through :func:`on_compile`), and so does every call
  once a compiled kernel has run in the process, since numba's start-up is paid by then.

Both versions of a kernel run the same source; the kernels it calls are bound to their plain
or compiled versions alike (the function is rebuilt over a copy of its module's globals in
which every kernel is replaced by that version), so a plain call never pays a dispatch per
nested scalar call. ``tests/test_jit.py`` holds the two to the same results on random programs.

``NCSIM_KERNELS`` = ``auto`` (the default), ``python`` or ``compiled`` forces the choice for a
process; :func:`forced` does the same within a ``with`` block (tests, ``ncsim warmup``).

numba compiles the kernels with ``error_model="numpy"``: a float division by zero gives inf or
nan, as in numpy, where numba's default tests every divisor to raise Python's
ZeroDivisionError -- a branch per division that costs 20-45 % on the per-arc closed forms of
``plan.arc_extrema``. The kernels guard their divisors (their plain-Python twins, which the
tests run on small inputs, would raise), so the results are the same.
"""
from __future__ import annotations

import os
import types
from contextlib import contextmanager
from typing import Callable

from ncsim.errors import UsageError

MODES = ("auto", "python", "compiled")
#: default ``python_below``. On CAM programs (``benchmarks/bench_startup.py``) a whole run in
#: plain Python stays cheaper than numba's start-up up to about 20,000 blocks (0.5 s of CPU
#: at 10,000 against 1.0 s compiled); half of that leaves room for costlier blocks
PYTHON_BELOW = 10_000
#: what :func:`on_compile`'s callback is told when numba starts compiling ncsim's kernels
COMPILE_NOTICE = ("ncsim: compiling kernels, once, about 10-20 s (cached for later runs; "
                  "`ncsim warmup` compiles them ahead)")

#: numba options of every kernel (module docstring); a change of them needs a new CACHE_TAG
COMPILE_OPTIONS = {"error_model": "numpy"}
CACHE_TAG = "npe"

_forced: str | None = None
_active = False                          # a compiled kernel has run in this process
_notice: Callable[[str], None] | None = None
_announced = False
_listening = False
_registry: list["Kernel"] = []
_namespaces: dict[tuple[str, int], dict] = {}
_dispatchers: set[int] = set()           # ids of the kernels' numba dispatchers


def on_compile(callback: Callable[[str], None] | None) -> None:
    """Call ``callback(COMPILE_NOTICE)`` once, when numba begins compiling an ncsim kernel
    (not when it loads one from its cache). The CLI prints it on stderr."""
    global _notice
    _notice = callback


def mode() -> str:
    """The mode in force: :func:`forced`, else ``NCSIM_KERNELS``, else ``auto``."""
    if _forced is not None:
        return _forced
    value = os.environ.get("NCSIM_KERNELS", "auto").strip().lower() or "auto"
    if value not in MODES:
        raise UsageError(f"NCSIM_KERNELS must be one of {', '.join(MODES)}, got {value!r}")
    return value


@contextmanager
def forced(which: str):
    """Run every kernel call in the block as ``python`` or ``compiled`` (or ``auto``)."""
    global _forced
    if which not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {which!r}")
    before, _forced = _forced, which
    try:
        yield
    finally:
        _forced = before


def numba_active() -> bool:
    """True once a compiled kernel has run in this process (numba is loaded)."""
    return _active


def _size(args) -> int:
    """The length of the first array (or bytes) argument: the rows a kernel works through
    (output buffers come later)."""
    for a in args:
        shape = getattr(a, "shape", None)
        if shape:
            return shape[0]
        if isinstance(a, (bytes, bytearray, memoryview, str)):
            return len(a)
    return 0


class Kernel:
    """A kernel function with its plain (:attr:`py`) and compiled (:attr:`compiled`) versions;
    calling it picks one by the size of the call (see the module docstring)."""

    def __init__(self, func, options: dict, python_below: int, python: Callable | None = None):
        self.func = func
        self.python = python
        self.options = options
        self.python_below = python_below
        self.__name__ = func.__name__
        self.__qualname__ = func.__qualname__
        self.__module__ = func.__module__
        self.__doc__ = func.__doc__
        self.__wrapped__ = func
        self._versions: dict[str, Callable] = {}

    def __repr__(self) -> str:
        return f"<kernel {self.__module__}.{self.__qualname__}>"

    def _version(self, which: str):
        """The function rebuilt over its module's globals with every kernel in them replaced
        by its ``which`` version (``python`` or ``compiled``); one namespace per module."""
        done = self._versions.get(which)
        if done is not None:
            return done
        if which == "python" and self.python is not None:
            self._versions[which] = self.python
            return self.python
        module_globals = self.func.__globals__
        key = (which, id(module_globals))
        namespace = _namespaces.get(key)
        fill = namespace is None
        if fill:
            namespace = _namespaces[key] = dict(module_globals)
        f = self.func
        rebuilt = types.FunctionType(f.__code__, namespace, f.__name__, f.__defaults__,
                                     f.__closure__)
        rebuilt.__kwdefaults__ = f.__kwdefaults__
        rebuilt.__qualname__ = f.__qualname__
        rebuilt.__doc__ = f.__doc__
        if which == "compiled":
            from numba import njit
            # numba names its cache files after the qualname and keys them on the code and
            # the signature, not on the options: the tag keeps caches of other options apart
            rebuilt.__qualname__ = f"{f.__qualname__}_{CACHE_TAG}"
            rebuilt = njit(cache=True, **{**COMPILE_OPTIONS, **self.options})(rebuilt)
            _dispatchers.add(id(rebuilt))
        self._versions[which] = rebuilt
        if fill:  # after storing ours, so that kernels calling each other resolve
            for name, value in list(namespace.items()):
                if isinstance(value, Kernel):
                    namespace[name] = value._version(which)
        return rebuilt

    @property
    def py(self):
        """The plain-Python version."""
        return self._version("python")

    @property
    def compiled(self):
        """numba's dispatcher (compiles or loads from the cache on its first call)."""
        return self._version("compiled")

    def pick(self, size: int) -> Callable:
        """The version a call over ``size`` items runs."""
        which = mode()
        if which == "python" or (which == "auto" and size < self.python_below and not _active):
            return self.py
        return self._run_compiled

    def runs_compiled(self, size: int) -> bool:
        """Whether a call over ``size`` items runs the compiled version."""
        return self.pick(size) is not self.py

    def _run_compiled(self, *args):
        global _active
        if not _listening:
            _listen()
        if _active:
            return self.compiled(*args)
        with _without_blas():             # numba's first load: its registries
            out = self.compiled(*args)
        _active = True
        return out

    def __call__(self, *args):
        return self.pick(_size(args))(*args)


def njit(func=None, *, cache: bool = True, python_below: int = PYTHON_BELOW,
         python: Callable | None = None, **numba_options):
    """Decorator with ``numba.njit``'s signature: make ``func`` a :class:`Kernel` (numba's
    options go to ``numba.njit`` when it compiles; ``cache`` must stay True). ``python``
    replaces the plain version where plain Python computes differently from numba
    (``np.cbrt`` of a float: numba calls libm's ``cbrt``, as ``math.cbrt`` does, numpy its
    own)."""
    if not cache:
        raise ValueError("ncsim's kernels are always cached (numba's cache=True)")

    def wrap(f):
        k = Kernel(f, numba_options, python_below, python)
        _registry.append(k)
        return k
    return wrap(func) if func is not None else wrap


def kernels() -> tuple[Kernel, ...]:
    """Every kernel defined so far (in the modules imported)."""
    return tuple(_registry)


_BLAS_MODULE = "scipy.linalg.cython_blas"


@contextmanager
def _without_blas():
    """numba's first compilation or cache load sets up its lowering registries, and one of
    them imports scipy.linalg to see whether BLAS is there (for ``np.dot`` and kin inside
    kernels): 0.2 s and 15 MB that every run would pay. ncsim's kernels use no BLAS, so that
    import is made to fail meanwhile (numba then uses its own loops, and would import
    scipy.linalg itself for a kernel that needs BLAS); an already imported scipy.linalg is
    left alone."""
    import sys

    if _BLAS_MODULE in sys.modules:
        yield
        return
    sys.modules[_BLAS_MODULE] = None     # "import scipy.linalg.cython_blas" raises ImportError
    try:
        yield
    finally:
        if sys.modules.get(_BLAS_MODULE, 0) is None:
            del sys.modules[_BLAS_MODULE]


def _listen() -> None:
    """Announce numba's first compilation of an ncsim kernel (its ``numba:compile`` event
    fires on a compilation, not on a cache load)."""
    global _listening
    from numba.core import event

    class Listener(event.Listener):
        def on_start(self, ev):
            global _announced
            dispatcher = ev.data.get("dispatcher") if isinstance(ev.data, dict) else None
            if not _announced and id(dispatcher) in _dispatchers and _notice is not None:
                _announced = True
                _notice(COMPILE_NOTICE)

        def on_end(self, ev):
            pass

    event.register("numba:compile", Listener())
    _listening = True
