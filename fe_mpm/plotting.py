"""Plots are optional: matplotlib comes with the ``plots`` extra (``pip install fe-mpm[plots]``)."""

from __future__ import annotations

from types import ModuleType


def pyplot() -> ModuleType | None:
    """``matplotlib.pyplot`` on the file-only Agg backend, or None without matplotlib.

    The demos write their CSV files either way; without matplotlib they say which
    plot they left out and how to get it.
    """
    try:
        import matplotlib
    except ImportError:
        print("  matplotlib is not installed, so no plot: pip install 'fe-mpm[plots]'")
        return None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
