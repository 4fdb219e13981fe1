"""Compare with Native: render the active camera in Cycles and natively, and show the error.

This module is the seam between the add-on and the comparison work (issue 6, "Render vs
native"). The operator `airmass.compare` calls

    run(context, *, camera=None, samples=16, output_folder=None, progress=None) -> dict

and reports the returned dict's "summary" string. `progress(fraction)` may be called with
a fraction in [0, 1]; returning True from it asks run() to stop (raise
native.NativeError with status CANCELLED). Errors are raised as exceptions whose message
names the problem; the operator turns them into reports.

Until the comparison is implemented, run() raises NotAvailable, which the operator
reports as "not available yet".
"""


class NotAvailable(NotImplementedError):
    pass


def available():
    return False


def run(context, *, camera=None, samples=16, output_folder=None, progress=None):
    raise NotAvailable("Compare with Native is not available yet in this version of the add-on "
                       "(it arrives with the render-vs-native comparison, issue 6)")
