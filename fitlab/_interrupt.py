"""Ctrl-C in the ``fitlab`` command: exit status 130, one line, and every output as it was.

Python turns SIGINT into a KeyboardInterrupt in whatever Python code the main thread runs next.  When
that code is a garbage-collector callback (JAX registers one, jax-ml/jax#18246) or a finaliser, the
exception is printed as "Exception ignored" and dropped: the command went on, wrote its outputs and
exited 0.  :func:`install` puts fitlab's own handler in place.  It records the request (a flag that stays
set) and then:

* raises KeyboardInterrupt at once where that is safe: in fitlab's own code or in the import machinery,
  outside the garbage collector;
* elsewhere raises nothing there: inside the collector (its callbacks, a ``__del__``) the exception would be
  dropped, and in a library's Python code called back from C++ (JAX's nanobind) it can end the process
  (``std::terminate``, status -6).  A helper thread delivers the signal again every few milliseconds
  until the main thread is in such a safe place (between the command's stages at the latest).  A
  KeyboardInterrupt raised where Python can only drop it after all (a weakref callback, as the import
  machinery's module-lock callback) reaches fitlab's ``sys.unraisablehook``, which prints nothing and
  delivers the request again;
* inside :func:`hold` (the renames that put a command's outputs into place, and a command's last part)
  raises nothing there either.  :func:`check`, which every write calls just before its renames
  (:func:`fitlab._io.atomic_write_many`), refuses the write (KeyboardInterrupt) when a request was made
  before it; a request after it comes too late to keep the old files, and the command ends as it would
  have (in a ``final`` hold: with its own exit status) or stops right after the renames (otherwise).

:func:`fitlab.cli.main` turns a request that was neither raised nor too late into exit status 130 even
when the command returned normally.  Only the ``fitlab`` command installs the handler: importing fitlab
changes no signal handling.
"""

from __future__ import annotations

import _thread
import gc
import os
import signal
import sys
import threading
import time
from contextlib import contextmanager

__all__ = ["install", "uninstall", "requested", "check", "hold", "close"]

_requested = False  # Ctrl-C was pressed (stays set)
_accepted = False  # ... after the command's outputs were complete: its exit status stands
_depth = 0  # nesting of hold()
_checked = False  # a check() passed inside the current outermost hold()
_late = False  # a request came after that check
_done = False  # the command's last part (a final hold) has ended, or main() has returned
_in_gc = False  # the collector is running (between its "start" and its "stop" callbacks)
_pending = False  # a request made where raising is unsafe waits to be raised
_previous = None  # the handler install() replaced
_previous_unraisable = None  # the sys.unraisablehook install() replaced
_delivery = threading.Lock()  # held while the helper thread delivers SIGINT again, and by uninstall() to stop it


def _reset() -> None:
    global _requested, _accepted, _depth, _checked, _late, _done, _pending
    _requested = _accepted = _checked = _late = _done = _pending = False
    _depth = 0


def _gc_phase(phase, info) -> None:
    global _in_gc
    _in_gc = phase == "start"  # first in gc.callbacks: "stop" clears it before the other stop callbacks run


#: where a KeyboardInterrupt may be raised: fitlab's own code and the import machinery (never called back from C++)
_FITLAB = os.path.dirname(os.path.abspath(__file__)) + os.sep
_IMPORTLIB = ("<frozen importlib._bootstrap>", "<frozen importlib._bootstrap_external>")


def _safe(frame) -> bool:
    """Whether KeyboardInterrupt may be raised in ``frame`` (the main thread's innermost Python frame): it runs
    fitlab's code or the import machinery, and not inside the garbage collector (the collector's flag, or a
    gc callback or a ``__del__`` on the stack, where a raised exception would be dropped)."""
    if frame is None or _in_gc:
        return False
    where = frame.f_code.co_filename
    if not (where.startswith(_FITLAB) or where in _IMPORTLIB):
        return False
    codes = {getattr(cb, "__code__", None) for cb in list(gc.callbacks)}
    while frame is not None:
        if frame.f_code in codes or frame.f_code.co_name == "__del__":
            return False
        frame = frame.f_back
    return True


def _deliver_again() -> None:
    """Send SIGINT to the main thread again, every few milliseconds, until its handler has raised (runs in a
    helper thread).  Under ``_delivery``, which :func:`uninstall` takes to end the deliveries: none is sent
    after it, so none reaches the handler put back (it would raise KeyboardInterrupt in whatever runs next)."""
    while True:
        time.sleep(0.005)
        with _delivery:
            if not _pending or _done:
                return
            if not _depth:
                _thread.interrupt_main(signal.SIGINT)


def _interrupt():
    """KeyboardInterrupt, raised by fitlab for the request (no delivery waits any more)."""
    global _pending
    _pending = False
    return KeyboardInterrupt()


def _redeliver() -> None:
    """Deliver the request again from a helper thread until the main thread raises it in a safe place."""
    global _pending
    if not _pending:
        _pending = True
        threading.Thread(target=_deliver_again, name="fitlab-sigint", daemon=True).start()


def _unraisable(args) -> None:
    """sys.unraisablehook while the handler is in place: fitlab's KeyboardInterrupt raised where Python can
    only drop it (a weakref callback, such as the import machinery's module-lock ``cb``, or a finaliser that
    :func:`_safe` cannot see) is neither printed nor lost: the request is delivered again.  Anything else
    goes to the hook that was there before."""
    if issubclass(args.exc_type, KeyboardInterrupt) and _requested and not _accepted and not _done:
        _redeliver()
        return
    (_previous_unraisable or sys.__unraisablehook__)(args)


def _handler(signum, frame) -> None:
    global _requested, _accepted, _late, _pending
    _requested = True
    if _done:
        _accepted = True
        return
    if _depth:
        _late = _late or _checked
        return
    if not _safe(frame):
        _redeliver()
        return
    raise _interrupt()


def install():
    """Put fitlab's SIGINT handler in place (main thread only; elsewhere nothing), with no request yet
    (when it is in place already, its state stays); returns the handler it replaced (for :func:`uninstall`)."""
    global _previous, _previous_unraisable
    if threading.current_thread() is not threading.main_thread():
        _reset()
        return None
    if signal.getsignal(signal.SIGINT) is not _handler:  # installed already (python -m fitlab): keep its state
        _reset()
        _previous = signal.signal(signal.SIGINT, _handler)
    if sys.unraisablehook is not _unraisable:
        _previous_unraisable, sys.unraisablehook = sys.unraisablehook, _unraisable
    if _gc_phase not in gc.callbacks:
        gc.callbacks.insert(0, _gc_phase)
    return _previous


def uninstall() -> None:
    """Put back the handler and the unraisable hook :func:`install` replaced (a ``fitlab.cli.main`` call from
    Python, e.g. a test)."""
    global _previous, _previous_unraisable, _in_gc, _done, _pending
    if threading.current_thread() is not threading.main_thread():
        return
    with _delivery:  # no delivery after this; one already sent runs _handler (done: it does nothing) in the
        _done, _pending = True, False  # signal.signal below, which handles pending signals first
    if signal.getsignal(signal.SIGINT) is _handler:
        signal.signal(signal.SIGINT, _previous if _previous is not None else signal.default_int_handler)
    _previous = None
    if sys.unraisablehook is _unraisable:
        sys.unraisablehook = _previous_unraisable or sys.__unraisablehook__
    _previous_unraisable = None
    while _gc_phase in gc.callbacks:
        gc.callbacks.remove(_gc_phase)
    _in_gc = False
    _reset()


def requested() -> bool:
    """Whether Ctrl-C was pressed and its request still stands (it did not come after the outputs were
    complete)."""
    return _requested and not _accepted


def check() -> None:
    """Raise KeyboardInterrupt if Ctrl-C was pressed: a writer calls it just before it renames its files into
    place.  Inside :func:`hold`, a request after a passed check is late."""
    global _checked
    if _requested and not _accepted and not _late:
        raise _interrupt()
    if _depth:
        _checked = True


@contextmanager
def hold(final: bool = False):
    """SIGINT is recorded, not raised, inside: the renames of a write (and, ``final``, a command's last part:
    its write and what it prints about it).  On leaving the outermost hold: a request made before a passed
    :func:`check` raises KeyboardInterrupt; one made after it is late: ``final``, the command ends as it would
    have; otherwise it raises KeyboardInterrupt now (the outputs just written stay)."""
    global _depth, _checked, _late, _done, _accepted
    _depth += 1
    ok = False
    try:
        yield
        ok = True
    finally:
        _depth -= 1
        if _depth == 0:
            late = _late
            _checked = _late = False
            if _requested and not _accepted:
                if late and final and ok:
                    _accepted = True
                else:
                    raise _interrupt()
            if final and ok:
                _done = True


def close(ignore: bool = False) -> None:
    """The command's exit status is settled: a later Ctrl-C changes nothing.  ``ignore`` (the ``fitlab``
    process, whose interpreter now shuts down): SIGINT is ignored from here to the exit, since Python puts
    the default action (death by SIGINT) back while it finalises, and JAX's threads take a while to end."""
    global _done
    _done = True
    if ignore and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        # CPython remembers a KeyboardInterrupt that left an exec() of a string (a dataclass being made when
        # Ctrl-C came), even one caught, and then ends `python -m` by SIGINT whatever its exit status; a
        # successful exec() of a string forgets it.
        exec("None", {})
