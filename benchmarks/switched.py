"""Event location for piecewise-smooth drives, shared by the benchmarks.

A backlash loop is smooth inside each contact mode.  Integrating it with the mode
held and restarting at every switch, located as a zero of a continuous guard, keeps
the integrator's order across switches; this is solve_ivp at its best.

The switching surfaces of a law are written once, as functions ``g(x, v)`` of
``theta_d`` and its rate (vectorised, so that the benchmarks' exact reference can scan
a whole grid of states at once), and wrapped for solve_ivp by :func:`on_state`.
"""

import numpy as np
from scipy.integrate import solve_ivp

from backlash_df import theta_star

IMPLICIT = ("Radau", "BDF", "LSODA")  # the methods that take a Jacobian


def solve_modes(rhs_of, guards_of, z0, mode, t_end, t_eval, method, rtol, jac_of=None):
    """The state on ``t_eval``, integrated mode by mode with solve_ivp.

    Parameters
    ----------
    rhs_of : callable
        ``rhs_of(mode)`` gives ``f(t, z)``, smooth, for solve_ivp.
    guards_of : callable
        ``guards_of(mode)`` gives ``[(g, next_mode), ...]``: ``g(t, z)`` is positive
        while ``mode`` holds and falls through zero where ``next_mode`` begins.
    z0, mode : ndarray, int
        Initial state and mode.
    t_end, t_eval : float, ndarray
        End time (s) and output times (s, increasing, in ``[0, t_end]``).
    method, rtol : str, float
        solve_ivp's method and relative tolerance (``atol = 1e-3 rtol``).
    jac_of : callable, optional
        ``jac_of(mode)`` gives the Jacobian, passed to the implicit methods.

    Returns
    -------
    states : ndarray, shape (len(z0), len(t_eval))
    nfev : int
        Right-hand side evaluations over all segments (the implicit methods' finite
        differences included).
    switches : int
    """
    t, z = 0.0, np.asarray(z0, dtype=float)
    out = np.full((z.size, t_eval.size), np.nan)
    nfev = switches = 0
    while True:
        pairs = guards_of(mode)
        for g, _ in pairs:
            g.terminal, g.direction = True, -1.0
        first = int(np.searchsorted(t_eval, t))
        options = {"jac": jac_of(mode)} if jac_of is not None and method in IMPLICIT else {}
        sol = solve_ivp(rhs_of(mode), (t, t_end), z, method=method, rtol=rtol, atol=rtol * 1e-3,
                        t_eval=t_eval[first:], events=[g for g, _ in pairs], **options)
        if len(sol.t):  # a segment between two switches may hold no output time (then solve_ivp gives lists)
            out[:, first:first + len(sol.t)] = sol.y
        nfev += sol.nfev
        hit = [i for i, times in enumerate(sol.t_events) if times.size]
        if sol.status != 1 or not hit:
            return out, nfev, switches
        t, z, mode = sol.t_events[hit[0]][0], sol.y_events[hit[0]][0], pairs[hit[0]][1]
        switches += 1


def solve_switched(rhs_of, guards_of, z0, mode, t_end, t_eval, method, rtol, row=0):
    """Component ``row`` of the state on ``t_eval``, integrated mode by mode (:func:`solve_modes`)."""
    return solve_modes(rhs_of, guards_of, z0, mode, t_end, t_eval, method, rtol)[0][row]


def on_state(surfaces, xv):
    """Guards ``g(t, z)`` for solve_ivp from surfaces ``g(x, v)``; ``xv(z)`` gives (theta_d, dtheta_d)."""
    return [((lambda t, z, g=g: float(g(*xv(z)))), next_mode) for g, next_mode in surfaces]


def phase_plane_surfaces(mode, k, c, alpha):
    """Switching surfaces ``[(g(x, v), next_mode)]`` of the phase plane law (19)-(23), contact held until release.

    Contact (``mode`` +-2) ends where ``k (x -+ alpha) + c v`` changes sign (Theorem 1);
    the free shaft closes on the right where x reaches theta*(v) (v > 0, eq. (19)) or
    ``k (x - alpha) + c v = 0`` (v <= 0), on the left by symmetry.  Every ``g`` takes
    scalars or arrays.
    """
    def closing(side):
        def g(x, v):
            x, v = side * x, side * v
            return np.where(v > 0.0, theta_star(v, k, c, alpha), alpha - c * v / k) - x
        return g

    def release(x, v):
        return mode / 2 * (k * (x - mode / 2 * alpha) + c * v)

    return [(release, 0)] if mode else [(closing(1), 2), (closing(-1), -2)]


def dead_zone_surfaces(mode, alpha):
    """Switching surfaces of the dead-zone laws (24)-(26): contact (``mode`` +-2) wherever ``|x| > alpha``."""
    if mode:
        return [(lambda x, v: mode / 2 * x - alpha, 0)]
    return [(lambda x, v: alpha - x, 2), (lambda x, v: alpha + x, -2)]


def phase_plane_guards(mode, xv, k, c, alpha):
    """Guards ``g(t, z)`` of the phase plane law for solve_ivp (:func:`phase_plane_surfaces`)."""
    return on_state(phase_plane_surfaces(mode, k, c, alpha), xv)
