"""The watchdog over plugin calls: no plugin can hang a run, or keep it from stopping.

Every call into a plugin (``handle``, a source's next message, ``start``, ``finish``)
is made between :meth:`Watchdog.enter` and :meth:`Watchdog.leave` with the component's
time limit (the pipeline's ``watchdog:``, default :data:`DEFAULT_LIMIT_S`; ``start`` and
``finish`` get :data:`LIFECYCLE_FACTOR` times as long). A thread checks the call in
progress; one that runs past its limit is interrupted with :class:`PluginTimeout`,
which the bus reports as that component's fault (``plugin_fault``) and handles by its
``on_error`` policy: by default it gets no more of that firefighter's data, everyone
else carries on. The interruption reaches plugin Python code and, when the run is in
the main thread, a blocking call such as ``time.sleep`` too (a signal, ``SIGUSR1``,
wakes it); it is repeated every further limit while the call does not return.

Stopping: the runner calls :meth:`Watchdog.hurry` when asked to stop (SIGTERM, Ctrl-C):
from then on every call, the one in progress included, has at most
:data:`STOP_GRACE_S`; one that takes longer is cut short with
:class:`PluginInterrupted` (and the plugin disabled), so a hung plugin cannot keep a
run from ending, while a healthy call is never cut. A ``KeyboardInterrupt`` or
``SystemExit`` a plugin raises itself is just that plugin's fault.

What cannot be interrupted from Python: code stuck in native code that holds the
interpreter (a compiled loop, a pathological regular expression), and a plugin that
catches ``BaseException`` and carries on. With ``hard_exit`` (``firenav run`` sets it)
the process then ends with status 1 after printing where every thread is: when a call
is still running :data:`HARD_EXIT_FACTOR` limits after its deadline, also when the
watchdog's own thread cannot run meanwhile (it keeps
:func:`faulthandler.dump_traceback_later` re-armed to that moment). The kit is restarted instead of
frozen, and the raw recordings written so far are intact.
"""
from __future__ import annotations

import ctypes
import faulthandler
import logging
import math
import os
import signal
import sys
import threading
import time
from typing import NamedTuple

__all__ = ["PluginTimeout", "PluginInterrupted", "Watchdog", "DEFAULT_LIMIT_S",
           "LIFECYCLE_FACTOR", "HARD_EXIT_FACTOR", "STOP_GRACE_S"]

#: Seconds a plugin call may take unless the pipeline says otherwise (``watchdog:``).
DEFAULT_LIMIT_S = 60.0
#: ``start`` and ``finish`` (compiling, loading a plan, writing a plot) get this many limits.
LIFECYCLE_FACTOR = 10.0
#: With ``hard_exit``: the process ends when a call is this many limits overdue.
HARD_EXIT_FACTOR = 10.0
#: Seconds any plugin call may still take once the run has been asked to stop.
STOP_GRACE_S = 2.0
WAKE_SIGNAL = signal.SIGUSR1

log = logging.getLogger("firenav.watchdog")


class PluginTimeout(BaseException):
    """A plugin call ran past its watchdog limit (a BaseException, so that a plugin's own
    ``except Exception`` cannot swallow it)."""


class PluginInterrupted(BaseException):
    """A plugin call was cut short because the run is stopping (SIGTERM, Ctrl-C)."""


class _Call(NamedTuple):
    """The plugin call in progress (a tuple: made once per call, so it must be cheap)."""

    token: int
    component: str
    what: str
    limit: float      # [s]; inf: not timed
    deadline: float   # monotonic [s]
    stopping: bool = False


def _text(call: _Call) -> str:
    if call.stopping:
        return (f"{call.what} of '{call.component}' did not return within {call.limit:g} s "
                "of the request to stop")
    return f"{call.what} of '{call.component}' did not return within {call.limit:g} s (watchdog)"


def _error(call: _Call) -> BaseException:
    return (PluginInterrupted if call.stopping else PluginTimeout)(_text(call))


class Watchdog:
    """Times the plugin call in progress (see the module docstring)."""

    def __init__(self, *, hard_exit: bool = False):
        self.hard_exit = hard_exit
        self.current: _Call | None = None
        self.user_interrupt = False   # the user insists (a second Ctrl-C): stop at once
        self.overruns = 0
        self._token = 0
        self._grace: float | None = None
        self._fired: dict[int, float] = {}  # token -> when it was last interrupted
        self._last = ""
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._owner = 0
        self._in_main = False
        self._saved_wake: object = None
        self._longest = DEFAULT_LIMIT_S

    # -- the calls ------------------------------------------------------------------
    def enter(self, component: str, limit: float | None, what: str = "handle") -> None:
        """A plugin call starts; ``limit`` [s] (None: not timed, unless stopping)."""
        self._token += 1
        limit = limit or math.inf
        if self._grace is not None:
            limit = min(limit, self._grace)
        self.current = _Call(self._token, component, what, limit,
                             time.monotonic() + limit, self._grace is not None)

    def leave(self) -> None:
        """The call in progress has returned (or raised)."""
        if self._in_main:
            self.current = None
            return
        with self._lock:  # another thread: no interruption may be injected after this
            call, self.current = self.current, None
            if call is not None and call.token in self._fired:
                _async_raise(self._owner, None)

    def hurry(self, grace: float = STOP_GRACE_S) -> None:
        """The run is stopping: every call, the current one too, gets ``grace`` seconds."""
        self._grace = grace
        call = self.current
        if call is not None:
            self.current = call._replace(limit=min(call.limit, grace), stopping=True,
                                         deadline=min(call.deadline, time.monotonic() + grace))

    def last_overrun(self) -> str:
        """What the last interruption was about (one raised in another thread carries no
        message of its own)."""
        return self._last

    # -- running --------------------------------------------------------------------
    def start(self, longest_limit: float) -> None:
        """Begin watching calls made from the calling (pipeline) thread."""
        self._owner = threading.get_ident()
        self._in_main = threading.current_thread() is threading.main_thread()
        self._longest = longest_limit or DEFAULT_LIMIT_S
        if self._in_main:
            self._saved_wake = signal.signal(WAKE_SIGNAL, self._on_wake)
        if self.hard_exit:  # armed here too: the thread may not get to run before a hang
            _arm_exit(HARD_EXIT_FACTOR * self._longest + 1.0)
        self._stop.clear()
        self._thread = threading.Thread(target=self._watch, name="firenav-watchdog",
                                        daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self.hard_exit:
            faulthandler.cancel_dump_traceback_later()
        if self._in_main:
            signal.signal(WAKE_SIGNAL, self._saved_wake)  # type: ignore[arg-type]

    # -- internals --------------------------------------------------------------------
    def _on_wake(self, signum: int, frame: object) -> None:
        call = self.current
        if call is not None and call.token in self._fired:
            raise _error(call)

    def _watch(self) -> None:
        poll = 0.05
        while not self._stop.wait(poll):
            call, now = self.current, time.monotonic()
            timed = call is not None and call.deadline != math.inf
            if self.hard_exit:  # the dead man's switch, in case this thread is starved
                budget = (call.deadline - now + HARD_EXIT_FACTOR * call.limit if timed
                          else HARD_EXIT_FACTOR * self._longest)
                _arm_exit(max(1.0, budget) + 1.0)
            if not timed:
                poll = 0.05
                continue
            poll = min(1.0, max(0.01, call.limit / 4))
            last = self._fired.get(call.token)
            if self.hard_exit and now > call.deadline + HARD_EXIT_FACTOR * call.limit:
                self._exit(call)
            if now >= call.deadline and (last is None or now - last >= call.limit):
                self._fire(call, now, first=last is None)

    def _fire(self, call: _Call, now: float, first: bool) -> None:
        """Interrupt ``call`` (repeated every limit while it does not return)."""
        with self._lock:
            if self.current is not call:
                return
            self._fired = {call.token: now}
            self._last = _text(call)
            if self._in_main:
                signal.pthread_kill(self._owner, WAKE_SIGNAL)
            else:
                _async_raise(self._owner, PluginInterrupted if call.stopping else PluginTimeout)
        self.overruns += first

    @staticmethod
    def _exit(call: _Call) -> None:
        """The last resort: a call that cannot be stopped ends the process."""
        log.critical("%s and cannot be interrupted (native code, or it ignores the "
                     "interruption); ending the process", _text(call))
        sys.stderr.flush()
        faulthandler.dump_traceback(_stderr(), all_threads=True)
        os._exit(1)


def _stderr():
    """The process's standard error (``sys.stderr`` may be replaced by one without a file
    descriptor, e.g. under pytest)."""
    try:
        sys.stderr.fileno()
        return sys.stderr
    except (AttributeError, ValueError, OSError):
        return sys.__stderr__


def _arm_exit(seconds: float) -> None:
    """(Re-)arm the dead man's switch: dump every thread and exit(1) in ``seconds``."""
    faulthandler.dump_traceback_later(seconds, exit=True, file=_stderr())


def _async_raise(thread_id: int, exc: type[BaseException] | None) -> None:
    """Raise ``exc`` in another thread at its next bytecode (None: cancel a pending one)."""
    ctypes.pythonapi.PyThreadState_SetAsyncExc(
        ctypes.c_ulong(thread_id), ctypes.py_object(exc) if exc is not None else None)
