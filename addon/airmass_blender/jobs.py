"""Long native work with progress and cancellation, for operators.

An operator describes its work as a Plan:
  * `work(progress)`  — pure computation (native calls, files); no bpy access, so it may
                        run on a worker thread; returns a result;
  * `finish(context, result)` — builds Blender data on the main thread;
  * `abort()`         — removes whatever `work` wrote (called on failure/cancel);
  * `drain(context)`  — optional, main thread: hands over what `work` produced so far (a
                        worker may queue results that need bpy, e.g. images to encode);
                        called on every timer tick while the work runs and once before
                        `finish`.

`execute` runs the work on the calling thread with wm.progress_* (no-ops in background
mode), so scripts and tests get a synchronous, deterministic operator. `invoke` (from the
UI) runs the work on a Python thread — ctypes releases the GIL during the native call —
while a modal timer updates the progress indicator and Esc requests cancellation: the UI
stays responsive and the native library stops at its next poll, leaving no file.
"""

import threading
import traceback

import bpy

from . import native
from .properties import SettingsError


class JobError(RuntimeError):
    """A failure whose message is written for the user (reported without a traceback)."""


class Plan:
    """`status` (optional): a short description of the current step, shown in the status bar
    while the work runs from the UI."""

    status = ""

    def work(self, progress):
        raise NotImplementedError

    def finish(self, context, result):
        raise NotImplementedError

    def abort(self):
        pass

    def drain(self, context):
        pass

    label = "Airmass"


def describe(exc):
    """A one-line message for self.report."""
    if isinstance(exc, (native.NativeError, SettingsError, JobError)):
        return str(exc)
    return "%s: %s" % (type(exc).__name__, exc)


class JobOperatorMixin:
    """Mixin for operators whose `make_plan(context)` returns a Plan (or raises)."""

    _timer = None
    _thread = None
    _plan = None
    _progress = None
    _outcome = None
    _outcome_error = None
    _shown_status = None

    def make_plan(self, context):
        raise NotImplementedError

    # -- synchronous ------------------------------------------------------------------------
    def execute(self, context):
        try:
            plan = self.make_plan(context)
        except Exception as e:  # noqa: BLE001 — every failure becomes a report
            self.report({"ERROR"}, describe(e))
            return {"CANCELLED"}
        wm = context.window_manager
        progress = None
        wm.progress_begin(0, 1000)
        try:
            def on_progress(fraction):
                wm.progress_update(int(1000 * fraction))
                return False  # never cancels: a blocking call has no Esc to listen to

            progress = native.Progress(on_progress)
            result = plan.work(progress)
            plan.finish(context, result)
        except Exception as e:  # noqa: BLE001
            plan.abort()
            if isinstance(e, native.NativeError) and e.cancelled:
                self.report({"WARNING"}, "%s cancelled: nothing was changed" % plan.label)
            else:
                if not isinstance(e, (native.NativeError, SettingsError, JobError)):
                    traceback.print_exc()
                self.report({"ERROR"}, describe(e))
            return {"CANCELLED"}
        finally:
            wm.progress_end()
            if progress is not None:
                progress.close()
        self.report_success(context, plan)
        return {"FINISHED"}

    def report_success(self, context, plan):
        message = getattr(plan, "summary", None)
        if message:
            self.report({"INFO"}, message)

    # -- asynchronous (UI) --------------------------------------------------------------------
    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._plan = self.make_plan(context)
            self._progress = native.Progress(None)
        except Exception as e:  # noqa: BLE001
            self.report({"ERROR"}, describe(e))
            return {"CANCELLED"}
        self._outcome = None
        self._outcome_error = None
        self._shown_status = None

        def run():
            try:
                self._outcome = ("ok", self._plan.work(self._progress))
            except Exception as e:  # noqa: BLE001
                self._outcome = ("error", e)

        self._thread = threading.Thread(target=run, name="airmass-job", daemon=True)
        self._thread.start()
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        context.workspace.status_text_set("%s… (Esc to cancel)" % self._plan.label)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self._progress.cancel()
        if event.type != "TIMER":
            return {"RUNNING_MODAL"} if event.type == "ESC" else {"PASS_THROUGH"}
        context.window_manager.progress_update(int(1000 * self._progress.fraction))
        try:
            self._plan.drain(context)
        except Exception as e:  # noqa: BLE001 — the worker stops at its next poll
            self._progress.cancel()
            self._outcome_error = e
        if self._plan.status and self._plan.status != self._shown_status:  # each change redraws the window
            self._shown_status = self._plan.status
            context.workspace.status_text_set("%s: %s… (Esc to cancel)" % (self._plan.label, self._plan.status))
        if self._thread.is_alive():
            return {"RUNNING_MODAL"}
        return self._complete(context)

    def _complete(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        self._progress.close()
        kind, value = self._outcome or ("error", RuntimeError("the worker thread ended without a result"))
        if self._outcome_error is not None:  # drain failed: that error, not the cancel it caused
            kind, value = "error", self._outcome_error
        if kind == "ok":
            try:
                self._plan.drain(context)
                self._plan.finish(context, value)
            except Exception as e:  # noqa: BLE001
                self._plan.abort()
                traceback.print_exc()
                self.report({"ERROR"}, describe(e))
                return {"CANCELLED"}
            self.report_success(context, self._plan)
            return {"FINISHED"}
        self._plan.abort()
        if isinstance(value, native.NativeError) and value.cancelled:
            self.report({"WARNING"}, "%s cancelled: nothing was changed" % self._plan.label)
        else:
            self.report({"ERROR"}, describe(value))
        return {"CANCELLED"}
