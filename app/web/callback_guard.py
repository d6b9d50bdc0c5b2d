"""One guard around every callback a tab sets off: an unexpected exception becomes one line in
that tab ("Something went wrong while …; your work is kept") and its traceback in the log.

viser 1.1.1 runs plain `def` callbacks (GUI edits and clicks, uploads, keyboard commands,
scene clicks, gizmo drags, tab connects and disconnects) by submitting them to the one
`ThreadPoolExecutor` the server owns (`ViserServer._thread_executor`, shared by its GuiApi and
SceneApi and by every tab's). When one raises, viser prints the traceback to stderr and the tab
hears nothing: the user is left with a panel that says "Loading…" forever. `guard_callbacks`
wraps that executor's `submit`, so every callback runs inside `_Guarded`, whatever session
registered it. A session's own error handling (a refused file, an infeasible solve) still
answers first, in its own words; this guard is for what nobody foresaw.

The reach into viser is checked: if the server no longer has the executor, `guard_callbacks`
raises `ViserHookError` (tests/studio/test_callback_guard.py runs it on every test run).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

import viser

from app.web.viser_internals import callback_executor

log = logging.getLogger(__name__)

Report = Callable[[str, str, "viser.ClientHandle | None"], None]
"""(title, one-line body, acting tab or None): how the guard tells the user."""

_MARK = "_biped_studio_guarded"


def guard_callbacks(server: viser.ViserServer, report: Report) -> None:
    """From now on, an exception escaping any of `server`'s callbacks is logged with its
    traceback and reported to the tab whose action it was (`report`)."""
    executor = callback_executor(server)  # raises ViserHookError if viser moved it
    if getattr(executor, _MARK, False):
        return
    submit = executor.submit

    def guarded_submit(fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        try:
            return submit(_Guarded(fn, report), *args, **kwargs)
        except RuntimeError:
            if not getattr(executor, "_shutdown", False):
                raise
            # The studio stopped with tabs still open: viser still dispatches their
            # disconnects, which have nothing left to run on. Nothing to do, nothing to say.
            skipped: Future[Any] = Future()
            skipped.set_result(None)
            return skipped

    executor.submit = guarded_submit  # type: ignore[method-assign]
    setattr(executor, _MARK, True)


class _Guarded:
    """`fn` run so that an exception is reported, not raised (viser would only print it)."""

    def __init__(self, fn: Callable[..., Any], report: Report) -> None:
        self._fn, self._report = fn, report

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        try:
            return self._fn(*args, **kwargs)
        except Exception as error:
            what = describe(args[0] if args else None)
            log.error("unexpected error while handling %s", what, exc_info=True)
            lines = str(error).strip().splitlines()
            first = f"{type(error).__name__}: {lines[0]}" if lines else type(error).__name__
            try:
                self._report(
                    "Something went wrong",
                    f"Something went wrong while handling {what}: {first[:300]}. "
                    "Your work is kept; the studio log has the details.",
                    acting_client(args[0] if args else None),
                )
            except Exception:  # the tab is gone, or the report itself failed: the log has it
                log.error("could not report the error to the tab", exc_info=True)
            return None


def describe(event: object) -> str:
    """The user's action behind a callback's argument, in words ("*Load built-in*")."""
    target = getattr(event, "target", None)
    label = getattr(target, "label", None)
    if isinstance(label, str) and label:
        return f"*{label}*"
    if isinstance(event, viser.ClientHandle):
        return "a tab's connection"
    name = getattr(target, "name", None)
    if isinstance(name, str) and name:
        return f"the scene's {name.rsplit('/', 1)[-1]}"
    return "an action in the page"


def acting_client(event: object) -> viser.ClientHandle | None:
    """The tab whose action it was, None when unknown (then every tab is told)."""
    if isinstance(event, viser.ClientHandle):
        return event
    client = getattr(event, "client", None)
    return client if isinstance(client, viser.ClientHandle) else None
