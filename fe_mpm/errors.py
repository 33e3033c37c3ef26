"""Errors that say where and when a run stopped."""


class ConvergenceError(RuntimeError):
    """Newton did not converge, or produced non-finite values, in a step."""


class PointsOutsideError(RuntimeError):
    """Material points left the background grid."""
