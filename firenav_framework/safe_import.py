"""Running third-party code at load time (plugin imports, hook functions) so that no
package can break a command.

:func:`import_object` imports ``module`` or ``module:attr`` and :func:`call_contained`
calls a package's function, each in a helper thread that is waited for at most
:func:`import_timeout` seconds (``$FIRENAV_IMPORT_TIMEOUT``, default 30). Every way it
can fail becomes a :class:`PluginImportError` naming what was run: any exception,
``SystemExit`` (a package calling ``sys.exit()``), a ``KeyboardInterrupt`` the package
raises itself, and a call that does not finish in time (the thread is left behind, a
daemon, and a module that hung is never imported again in this process). A real Ctrl-C
still interrupts the waiting command.
"""
from __future__ import annotations

import importlib
import math
import os
import sys
import threading
from collections.abc import Callable
from typing import Any

__all__ = ["PluginImportError", "import_object", "call_contained", "import_timeout"]

DEFAULT_TIMEOUT_S = 30.0

#: Modules whose import timed out: importing them again would wait on their lock forever.
_hung: set[str] = set()


class PluginImportError(ImportError):
    """A plugin's module, attribute or hook (``what``) could not be loaded: ``detail``."""

    def __init__(self, what: str, detail: str):
        super().__init__(f"{what}: {detail}")
        self.what, self.detail = what, detail


def import_timeout() -> float:
    """Seconds a package's import or hook may take: ``$FIRENAV_IMPORT_TIMEOUT``, else 30."""
    try:
        value = float(os.environ.get("FIRENAV_IMPORT_TIMEOUT", DEFAULT_TIMEOUT_S))
    except ValueError:
        return DEFAULT_TIMEOUT_S
    return value if value > 0 else DEFAULT_TIMEOUT_S


def call_contained(fn: Callable[[], Any], what: str, timeout: float | None = None) -> Any:
    """``fn()`` run in a helper thread for at most ``timeout`` s (infinity: as long as
    it takes); its result, or a :class:`PluginImportError` saying what went wrong in
    ``what``."""
    timeout = import_timeout() if timeout is None else timeout
    box: dict[str, Any] = {}

    def work() -> None:
        try:
            box["result"] = fn()
        except BaseException as exc:  # noqa: BLE001 - the package's fault, whatever it is
            box["error"] = exc

    thread = threading.Thread(target=work, name=f"load {what}", daemon=True)
    thread.start()
    thread.join(None if math.isinf(timeout) else timeout)
    if thread.is_alive():
        raise PluginImportError(what, f"did not finish within {timeout:g} s (it hangs; "
                                "FIRENAV_IMPORT_TIMEOUT sets the limit)")
    error = box.get("error")
    if error is not None:
        raise PluginImportError(what, f"{type(error).__name__}: {error}") from error
    return box["result"]


def import_object(target: str, timeout: float | None = None) -> object:
    """The object ``target`` (``module`` or ``module:attr.attr``) names.

    Raises :class:`PluginImportError` for every failure (see the module docstring).
    """
    module, _, attr = target.partition(":")
    if module in _hung:
        raise PluginImportError(target, "it hung at import earlier in this run")
    loaded = sys.modules.get(module)
    spec = getattr(loaded, "__spec__", None)
    if loaded is None or spec is None or getattr(spec, "_initializing", False):
        try:
            loaded = call_contained(lambda: importlib.import_module(module), target, timeout)
        except PluginImportError as exc:
            if exc.detail.startswith("did not finish"):
                _hung.add(module)
            raise
    obj: object = loaded
    try:
        for part in attr.split(".") if attr else ():
            obj = getattr(obj, part)
    except AttributeError as exc:
        raise PluginImportError(target, str(exc)) from None
    return obj
