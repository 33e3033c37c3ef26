"""How fast Newton's residual norms fall, for the convergence checks of the suite."""


def quadratic(norms):
    """Each contraction at least squares the previous one (up to round-off)."""
    rates = [b / a for a, b in zip(norms, norms[1:])]
    return all(
        r2 < 10 * r1**2 or b < 1e-9 * norms[0] for r1, r2, b in zip(rates, rates[1:], norms[2:])
    )


def accelerating(norms):
    """Each contraction ‖R_{k+1}‖/‖R_k‖ is smaller than the one before, down to round-off:
    superlinear convergence (a linear rate would stay constant)."""
    rates = [b / a for a, b in zip(norms, norms[1:])]
    return all(r2 < r1 or b < 1e-9 * norms[0] for r1, r2, b in zip(rates, rates[1:], norms[2:]))
