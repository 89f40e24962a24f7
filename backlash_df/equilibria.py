"""The rest points of a drive loop with backlash, their local stability, and how far a disturbance keeps them.

The loop cut at the backlash (:class:`~backlash_df.system.LinearPart`) rests where
every rate is zero.  A dead time then holds a constant (its delayed signals equal the
current ones), so a rest solves

    0 = (A + e_d d) z + b T + E w,     theta_d = c_x z,     T = T_s(theta_d)

with ``T_s`` the law's torque at ``dtheta_d = 0``: 0 in the gap, ``k (theta_d -+ alpha)``
in contact for the dead-zone family (24)-(27), the phase plane law (23) and the exact
model (1), (14), the rubber band's quadratic (36) inside ``alpha -+ beta / 2``.  The
bordered system ``[[A + e_d d, b], [c_x, 0]]`` gives ``z`` and ``T`` affinely in
``theta_d``, ``T = T_0 + T_1 theta_d``.  On a rig's loop the load's own equation,
``J_l dw_l/dt = T + T_l``, makes ``T = -T_l`` (``T_1 = 0``), and with the PI's integrator
the speed error is zero.  So

* without a load torque the loop rests **in the gap**, on a continuum ``|theta_d| <=
  alpha`` (the integrator at 0), represented by its middle ``theta_d = 0``;
* under a load torque it rests **on one flank**: ``k (theta_d -+ alpha) = -T_l``,
  ``theta_d = -sign(T_l) alpha - T_l / k`` for the affine laws, the integrator carrying
  the load (``u = -T_l``);
* with a torque limit below the command a rest needs, it has **no rest** (the limit cannot
  hold the load).

**Local stability** of a rest: the eigenvalues of its mode's matrix, the linearisation
there (for the affine laws the mode itself), with the dead time by its Pade approximant
(:func:`~backlash_df.system.with_pade`): on a flank the loop in contact, a rest there
stable iff that loop is; in the gap the open loop, marginal with a free load (a pole at
s = 0: the load coasts), so a rest in the gap is never asymptotically stable.

**Reach** of a rest: the largest disturbance of each kind (:mod:`backlash_df.disturbances`)
whose motion stays in the rest's mode.  Inside the mode the motion is the linear flow
``q(t) = q* + s Phi(t) delta`` of the disturbance ``s delta``, and every surface that ends
the mode is linear in the state (release ``k (theta_d -+ alpha) + c dtheta_d = 0`` by
Theorem 1, or ``theta_d = +-alpha`` for (24)-(26); contact, conservatively
``theta_d + (c/k) dtheta_d = +-alpha`` for the laws that re-contact at ``theta*(v)``,
which lies beyond it; the torque command's limit ``u = +-L``).  For a switching function
``g = g* + s n . Phi(t) delta`` (``g* > 0`` at the rest) the motion keeps the mode while
``|s| < g* / max_t (-sign(s) n . Phi(t) delta)``; the reach is the smaller over both signs,
signed towards the side that leaves first.  A flow that has not settled by its horizon
(a marginal or unstable mode) leaves the mode for any size: reach 0.
"""

import dataclasses
import math

import numpy as np

from ._laws import DAMPED_DEAD_ZONE, DEAD_ZONE, ELASTO_BACKLASH, RUBBER
from .disturbances import KINDS, MOTOR_SPEED, TWIST, Disturbance
from .loops import drive_loop
from .system import closed_loop_matrix, lti_linear_part, with_pade

__all__ = ["LinearStability", "linear_stability", "Rest", "rest_points", "loop_rests", "friction_band"]

#: Pade order of the dead time in every pole computation of the verdict and the rests.
PADE_ORDER = 8
_HORIZON_DECAYS = 8.0  # the reach's flow is followed for 8 time constants of its slowest decaying pole
_SAMPLES_PER_PERIOD = 32  # and sampled 32 times a period of its fastest oscillation
_MAX_SAMPLES = 2**15
_SETTLED = 1e-2  # a response whose last eighth varies by less than this share of its range has settled


# --------------------------------------------------------------------------- linear loops


@dataclasses.dataclass(frozen=True)
class LinearStability:
    """Stability of the loop with the backlash replaced by a linear shaft.

    Attributes
    ----------
    regime : str
        ``"contact"`` (``T = k theta_d + c dtheta_d``), ``"open"`` (``T = 0``) or
        ``"rubber band"`` (the band's local stiffness and damping at a rest in it).
    poles : ndarray of complex
        Closed-loop poles, 1/s, by decreasing real part (with the dead time's
        Pade poles when the loop has one).
    pade_order : int
        Order of the Pade approximation of the dead time (0 without one).
    """

    regime: str
    poles: np.ndarray
    pade_order: int

    @property
    def max_real(self):
        """Largest real part of the poles, 1/s."""
        return float(self.poles[0].real)

    @property
    def stable(self):
        """All poles in the open left half plane."""
        return bool(self.max_real < -self._tolerance)

    @property
    def marginal(self):
        """No pole on the right, one or more on the imaginary axis (e.g. a free load)."""
        return abs(self.max_real) <= self._tolerance

    @property
    def _tolerance(self):
        return 1e-9 * max(np.abs(self.poles).max(), 1.0)

    @property
    def status(self):
        """``"stable"``, ``"marginal"`` or ``"unstable"``."""
        return "stable" if self.stable else "marginal" if self.marginal else "unstable"

    def describe(self):
        """One phrase: status and the rightmost pole, e.g. ``unstable (pole 8.6 +- 262j 1/s)``."""
        pole = self.poles[0]
        text = f"{pole.real:.4g}" + (f" +- {abs(pole.imag):.4g}j" if abs(pole.imag) > 0 else "")
        return f"{self.status} (rightmost pole {text} 1/s)"

    def __repr__(self):
        return (f"LinearStability({self.regime}: {self.describe()}, {self.poles.size} poles, "
                f"Pade order {self.pade_order})")

    def to_dict(self, count=6):
        """JSON entry: status, the rightmost ``count`` poles as ``[re, im]`` (1/s), Pade order."""
        return {
            "stable": bool(self.stable),
            "status": self.status,
            "max_real": self.max_real,
            "poles": [[float(p.real), float(p.imag)] for p in self.poles[:count]],
            "pade_order": int(self.pade_order),
        }


def linear_stability(part, stiffness, damping, regime="contact", pade_order=PADE_ORDER):
    """Poles of a loop whose shaft is the linear spring-damper ``T = k theta_d + c dtheta_d``.

    Parameters
    ----------
    part : LinearPart
        The loop cut at the backlash (:meth:`DriveLoop.linear_part` or
        :func:`~backlash_df.system.lti_linear_part`).
    stiffness, damping : float
        k (N m/rad) and c (N m s/rad); ``0, 0`` for the open gear.
    regime : str
        Label stored in the result (``"contact"`` or ``"open"``).
    pade_order : int
        Pade order for the dead time, realised by :func:`backlash_df.system.with_pade`
        (the realisation the exact orbits use).

    Returns
    -------
    LinearStability

    Examples
    --------
    >>> from backlash_df import Plant, Controller, DriveLoop
    >>> loop = DriveLoop(Plant(0.4, 5.6, 5895.0, 0.05, damping=3.0), Controller(kp=30.0, ti=0.5))
    >>> linear_stability(loop.linear_part(), 5895.0, 3.0).status
    'stable'
    """
    order = int(pade_order) if part.delay > 0.0 else 0
    matrix = closed_loop_matrix(with_pade(part, order) if order else part, stiffness, damping)
    poles = np.linalg.eigvals(matrix)
    return LinearStability(regime, poles[np.argsort(-poles.real, kind="stable")], order)


def contact_shaft(model):
    """``(k, c)`` of a law's contact mode, N m/rad and N m s/rad: the dead zone (24) contacts without damping."""
    return model.stiffness, 0.0 if model.mode_law == DEAD_ZONE else model.damping


# --------------------------------------------------------------------------- rests


@dataclasses.dataclass(frozen=True)
class Rest:
    """A rest point (equilibrium) of the loop with one torque law, its local stability and its reach.

    Attributes
    ----------
    side : int
        -1 on the left flank, 0 in the gap, +1 on the right flank.
    theta_d : float
        rad.
    torque : float
        The shaft torque there, N m (``-T_l`` on a rig's loop).
    state : ndarray
        The loop's states at rest, ordered as ``state_names``.
    state_names : tuple of str
    stability : LinearStability
        The linearisation at the rest: the loop in contact on a flank, open in the gap.
    reach : tuple of Disturbance
        Per kind, the largest disturbance whose motion stays in the rest's mode, signed
        towards the side that leaves it first; empty where it is not computed (a
        rest in the rubber band).
    still : tuple of str
        The kinds whose disturbances within reach are rests themselves (a twist inside
        the gap of a speed loop).
    continuum : bool
        A rest in the gap without load: every ``|theta_d| <= alpha`` rests too.
    command : float
        The torque command at rest, N m (NaN without a torque limit).
    theta_b : float
        The exact model's backlash angle at rest, rad (``theta_d`` in the gap, ``+-alpha`` on a flank).
    """

    side: int
    theta_d: float
    torque: float
    state: np.ndarray = dataclasses.field(repr=False)
    state_names: tuple = dataclasses.field(repr=False)
    stability: LinearStability = dataclasses.field(repr=False)
    reach: tuple = ()
    still: tuple = ()
    continuum: bool = False
    command: float = math.nan
    theta_b: float = 0.0
    rows: tuple = dataclasses.field(default=None, repr=False, compare=False)  # (c_x, c_v) of the part

    @property
    def where(self):
        """``"in the gap"``, ``"on the left flank"`` or ``"on the right flank"``."""
        return "in the gap" if self.side == 0 else f"on the {'left' if self.side < 0 else 'right'} flank"

    @property
    def stable(self):
        """True if the linearisation at the rest is asymptotically stable (never in the gap of a free load)."""
        return self.stability.stable

    def reach_of(self, kind):
        """The reach of one kind (a Disturbance), or None where it is not computed or not defined."""
        return next((d for d in self.reach if d.kind == kind), None)

    def describe(self):
        """One phrase, e.g. ``on the left flank (theta_d = -0.06696 rad), stable``."""
        where = "in the gap (theta_d = 0 rad of |theta_d| <= alpha)" if self.continuum else \
            f"{self.where} (theta_d = {self.theta_d:.4g} rad)"
        return f"{where}, {self.stability.status}"

    def initial(self, disturbance=None):
        """The state by name of the rest disturbed by ``disturbance`` (``simulate(initial=...)``).

        A twist of a user's linear part (no ``theta_d`` state) is its least-norm
        state with ``theta_d`` changed by the value and ``dtheta_d`` unchanged.

        Raises
        ------
        ValueError
            A motor-speed kick on a linear part without a ``motor_speed`` state.
        """
        state = np.array(self.state, dtype=float)
        if disturbance is not None:
            if disturbance.state in self.state_names:
                state[self.state_names.index(disturbance.state)] += disturbance.value
            elif disturbance.kind == TWIST:
                state += np.linalg.pinv(np.array(self.rows)) @ np.array([disturbance.value, 0.0])
            else:
                raise ValueError(f"a {disturbance.kind} disturbance needs a {disturbance.state!r} state; the "
                                 f"loop's states are: {', '.join(self.state_names)}")
        return dict(zip(self.state_names, state.tolist()))

    def __repr__(self):
        return f"Rest({self.describe()})"

    def to_dict(self):
        """JSON entry: where (rad, N m), the local stability, the reach as disturbances, the state by name."""
        return {
            "where": self.where,
            "theta_d": float(self.theta_d),
            "torque": float(self.torque),
            "continuum": bool(self.continuum),
            "stable": bool(self.stable),
            "local": self.stability.to_dict(),
            "reach": [d.to_dict() for d in self.reach],
            "state": {name: float(value) for name, value in zip(self.state_names, self.state)},
        }


def rest_points(part, model, inputs=None, pade_order=PADE_ORDER):
    """The rests of a loop with one torque law (module docs), and why there is none.

    Parameters
    ----------
    part : LinearPart
        The loop cut at the backlash.
    model : BacklashModel
    inputs : array_like, optional
        The constant external inputs ``w`` (a rig's loop: speed or position
        reference 0 and the load torque ``T_l``, N m); default zero.
    pade_order : int
        Pade order of the dead time in the local stability and the reach.

    Returns
    -------
    rests : tuple of Rest
        By increasing ``theta_d``.
    note : str
        Why there is no rest (``""`` where there is one).

    Examples
    --------
    The loaded example rests on its left flank, ``theta_d = -alpha - T_l / k``:

    >>> import backlash_df as bd
    >>> rig = bd.rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
    ...     "damping": 3.0, "half_gap": 0.05}, "controller": {"kp": 30.0, "ti": 0.5}, "load": {"torque": 100.0}})
    >>> (rest,), _ = rest_points(bd.drive_loop(rig).linear_part(), rig.make_model(), [0.0, 100.0])
    >>> rest.where, round(rest.theta_d, 6), rest.stable
    ('on the left flank', -0.066964, True)
    """
    n = part.n_states
    w = np.zeros(part.E.shape[1]) if inputs is None else np.asarray(inputs, dtype=float)
    border = np.zeros((n + 1, n + 1))
    border[:n, :n] = part.A + part.e_d @ part.d
    border[:n, n], border[n, :n] = part.b, part.c_x
    rhs = np.zeros((n + 1, 2))
    rhs[:n, 0], rhs[n, 1] = -part.E @ w, 1.0
    try:
        solution = np.linalg.solve(border, rhs)
    except np.linalg.LinAlgError:  # a continuum of rests (or none): the least-norm one, checked below
        solution = np.linalg.lstsq(border, rhs, rcond=None)[0]
    # each row's size (the rows differ by 1e6 and more) times the solution's: round-off is relative to both
    scale = np.abs(border).sum(axis=1)[:, None] * np.abs(solution).max(axis=0) + np.abs(rhs)
    if not np.all(np.abs(border @ solution - rhs) <= 1e-9 * scale + 1e-300):
        return (), "the loop has no state with every rate zero"
    (z0, z1), (t0, t1) = solution[:n].T, solution[n]
    law = model.mode_law
    found, limited = [], []
    for side, theta, continuum in _rest_angles(model, law, t0, t1):
        z = z0 + theta * z1
        command = _command_at(part, z, w)
        if part.command is not None and abs(command) > part.command.limit * (1.0 + 1e-12):
            limited.append(command)
            continue
        found.append(_rest(part, model, law, side, theta, t0 + t1 * theta, z, w, command, continuum, pade_order))
    if not found and limited:
        return (), (f"the torque limit {part.command.limit:.4g} N m is below the command a rest needs "
                    f"({abs(limited[0]):.4g} N m): the loop cannot hold the load")
    return tuple(found), "" if found else "the law's static torque meets the loop's nowhere"


def loop_rests(rig, model, linear=None, pade_order=PADE_ORDER):
    """The rests of a rig's loop (speed or position reference 0, the rig's load torque), or of a user's LTI.

    Parameters
    ----------
    rig : Rig
    model : BacklashModel
    linear : control.LTI, optional
        A user's linear part G (shaft torque -> -theta_d) in place of the rig's loop (no inputs).
    pade_order : int

    Returns
    -------
    rests : tuple of Rest
    note : str
        As :func:`rest_points`.
    """
    if linear is not None:
        return rest_points(lti_linear_part(linear), model, pade_order=pade_order)
    return rest_points(drive_loop(rig, dry_friction=True).linear_part(), model, [0.0, rig.load.torque], pade_order)


def _rest_angles(model, law, t0, t1):
    """``(side, theta_d, continuum)`` of every solution of ``T_s(theta_d) = t0 + t1 theta_d``."""
    k, alpha = model.stiffness, model.half_gap
    beta = model.rubber_thickness if law == RUBBER else 0.0
    edge, tol = alpha - 0.5 * beta, 1e-12 * k * alpha
    out = []
    if abs(t1) * edge <= tol and abs(t0) <= tol:  # no torque anywhere: the gap's continuum, its edges included
        return [(0, 0.0, True)]
    if abs(t1) * edge > tol and abs(t0 / t1) <= edge:
        out.append((0, -t0 / t1, False))
    for side in (-1, 1):
        if beta == 0.0 and k != t1:
            theta = (t0 + side * k * alpha) / (k - t1)
            if side * theta > alpha:
                out.append((side, theta, False))
        elif beta > 0.0:
            theta = _rubber_rest(model, side, t0, t1, edge)
            if theta is not None:
                out.append((side, theta, False))
    return sorted(out, key=lambda item: item[1])


def _rubber_rest(model, side, t0, t1, edge):
    """theta_d beyond the gap edge on ``side`` where the rubber law's static torque meets ``t0 + t1 theta``."""
    def mismatch(theta):
        return float(model.torque(theta, 0.0)) - t0 - t1 * theta

    far = side * (edge + model.rubber_thickness + 2.0 * abs(t0) / model.stiffness + model.half_gap)
    near = side * edge
    if mismatch(near) * mismatch(far) >= 0.0:
        return None
    from scipy import optimize  # here: importing the package does not import scipy.optimize (0.2 s)

    return optimize.brentq(mismatch, min(near, far), max(near, far), xtol=1e-15, rtol=1e-15)


def _command_at(part, z, w):
    """The torque command u at the rest state (N m), its delayed signals equal to the current ones; NaN without a limit."""
    if part.command is None:
        return math.nan
    n, m = part.n_states, part.E.shape[1]
    row = part.command.row
    return float(row[:n] @ z + row[n:n + m] @ w + row[n + m:] @ (part.d @ z))


def _rest(part, model, law, side, theta, torque, z, w, command, continuum, pade_order):
    """The :class:`Rest` at ``theta``: local stability and reach."""
    k, c = contact_shaft(model)
    alpha, beta = model.half_gap, model.rubber_thickness if law == RUBBER else 0.0
    in_band = side != 0 and beta > 0.0 and abs(theta) < alpha + 0.5 * beta
    if side == 0:
        shafts, regime = [(0.0, 0.0)], "open"
    elif in_band:
        shafts, regime = _band_shafts(model, theta), "rubber band"
    else:
        shafts, regime = [(k, c)], "contact"
    stability = max((linear_stability(part, kk, cc, regime, pade_order) for kk, cc in shafts),
                    key=lambda s: s.max_real)
    reach, still = ((), ()) if in_band else _reach(part, model, law, side, theta, z, command, shafts[0], pade_order)
    theta_b = theta if side == 0 else side * alpha
    return Rest(side, float(theta), float(torque), z, part.state_names, stability, reach, still, continuum,
                command, float(theta_b), (part.c_x, part.c_v))


def _band_shafts(model, theta, step=1e-7):
    """The rubber band's local (k, c) at a rest in it: one per sign of dtheta_d, where (36) differs."""
    h = step * model.half_gap
    k_local = float(model.torque(theta + h, 0.0) - model.torque(theta - h, 0.0)) / (2.0 * h)
    v = step * model.half_gap * model.stiffness / max(model.damping, 1e-300)
    base = float(model.torque(theta, 0.0))
    return [(k_local, (float(model.torque(theta, v)) - base) / v), (k_local, (base - float(model.torque(theta, -v))) / v)]


# --------------------------------------------------------------------------- reach


def _boundaries(law, side, k, c, alpha, beta):
    """``(a_x, a_v, const)``: the linear functions ``a_x theta_d + a_v dtheta_d + const > 0`` that hold the mode."""
    if side == 0:
        if law == RUBBER:  # the band begins at alpha - beta/2 - 2 c v / k for v <= 0, beyond it for v > 0
            return [(-1.0, -2.0 * c / k, alpha - 0.5 * beta), (1.0, 2.0 * c / k, alpha - 0.5 * beta)]
        kappa = 0.0 if law in (DEAD_ZONE, DAMPED_DEAD_ZONE, ELASTO_BACKLASH) else c / k
        return [(-1.0, -kappa, alpha), (1.0, kappa, alpha)]
    if law in (DEAD_ZONE, DAMPED_DEAD_ZONE):
        right = [(1.0, 0.0, -alpha)]
    elif law in (ELASTO_BACKLASH, RUBBER):  # steel contact: beyond alpha (+ beta/2) and pressing
        right = [(1.0, 0.0, -alpha - 0.5 * beta), (k, c, -k * alpha)]
    else:
        right = [(k, c, -k * alpha)]  # Theorem 1: contact holds while k (x - alpha) + c v > 0
    return right if side > 0 else [(-a_x, -a_v, const) for a_x, a_v, const in right]


def _reach(part, model, law, side, theta, z, command, shaft, pade_order):
    """``(reach, still)`` of a rest (module docs): per kind the largest disturbance that keeps the mode."""
    k, c, alpha = model.stiffness, model.damping, model.half_gap
    beta = model.rubber_thickness if law == RUBBER else 0.0
    loop = with_pade(part, pade_order) if part.delay > 0.0 else part
    matrix = closed_loop_matrix(loop, *shaft)
    n, size = part.n_states, loop.n_states
    rows, margins = [], []
    for a_x, a_v, const in _boundaries(law, side, k, c, alpha, beta):
        rows.append(a_x * loop.c_x + a_v * loop.c_v)
        margins.append(a_x * theta + const)
    if part.command is not None:
        u_row = loop.command.row[:size] if part.delay > 0.0 else part.command.row[:n]
        rows += [-u_row, u_row]
        margins += [part.command.limit - command, part.command.limit + command]
    kinds = [kind for kind in KINDS if kind == TWIST or "motor_speed" in part.state_names]
    directions = np.column_stack([_direction(part, matrix, kind) for kind in kinds])
    responses = _flow(matrix, directions, closed_loop_matrix(part, *shaft), np.array(rows))
    margins = np.maximum(np.array(margins), 0.0)
    reach, still = [], []
    for j, kind in enumerate(kinds):
        response = responses[:, :, j]  # (samples, functions)
        settled = np.ptp(response[-response.shape[0] // 8:], axis=0) <= _SETTLED * np.ptp(
            np.vstack([response, np.zeros(response.shape[1])]), axis=0) + 1e-300
        sizes = {}
        for sign in (1.0, -1.0):
            push = (-sign * response).max(axis=0)
            limits = np.where(push > 0.0, margins / np.where(push > 0.0, push, 1.0), math.inf)
            sizes[sign] = float(limits.min()) if settled.all() else 0.0
        sign = min(sizes, key=sizes.get)
        if math.isfinite(sizes[sign]):
            reach.append(Disturbance(kind, sign * sizes[sign]))
        if not np.any(matrix @ directions[:, j]):
            still.append(kind)
    return tuple(reach), tuple(still)


def _direction(part, matrix, kind):
    """A unit disturbance of ``kind`` over the loop's states, its Pade states at rest for the constant history."""
    n, size = part.n_states, matrix.shape[0]
    delta = np.zeros(size)
    if kind == MOTOR_SPEED:
        delta[part.state_names.index("motor_speed")] = 1.0
    elif "theta_d" in part.state_names:
        delta[part.state_names.index("theta_d")] = 1.0
    else:
        delta[:n] = np.linalg.pinv(np.array([part.c_x, part.c_v])) @ np.array([1.0, 0.0])
    if size > n:  # the dead time's Pade states: steady for the disturbed signal it held before t = 0
        delta[n:] = -np.linalg.solve(matrix[n:, n:], matrix[n:, :n] @ delta[:n])
    return delta


def _flow(matrix, directions, undelayed, rows):
    """``rows @ expm(matrix t) @ directions`` on a grid over the flow's horizon: shape (samples, rows, directions)."""
    poles = np.linalg.eigvals(matrix)
    decaying = -poles.real[poles.real < -1e-9 * max(np.abs(poles).max(), 1.0)]
    horizon = _HORIZON_DECAYS / decaying.min() if decaying.size else 20.0
    fastest = np.abs(np.linalg.eigvals(undelayed).imag).max()
    step = horizon / 64.0 if fastest == 0.0 else min(horizon / 64.0, 2.0 * math.pi / (_SAMPLES_PER_PERIOD * fastest))
    samples = min(int(math.ceil(horizon / step)), _MAX_SAMPLES)
    from scipy import linalg  # here, as scipy.optimize above

    power = linalg.expm(matrix * (horizon / samples))
    states = np.empty((samples + 1,) + directions.shape)
    states[0] = directions
    filled = 1
    # a mode that grows (an unstable rest) overflows to inf and nan over the horizon: such a flow does
    # not settle, and the reach reads it so (:func:`_reach`), without a warning to the user
    with np.errstate(over="ignore", invalid="ignore"):
        while filled < samples + 1:  # states[filled + j] = power^filled states[j]
            count = min(filled, samples + 1 - filled)
            states[filled:filled + count] = np.einsum("ik,skd->sid", power, states[:count])
            power = power @ power
            filled += count
        return np.einsum("fi,sid->sfd", rows, states)


#: The states whose span :func:`friction_band` reports: the position a cascade holds, and the shaft's twist.
BAND_STATES = ("load_angle", "theta_d")
_BAND_RESOLUTION = 1e-9  # a band narrower than this share of its values (or of the gap) is round-off


def friction_band(rig, model, pade_order=PADE_ORDER):
    """The rests the load's dry friction holds: per position state, the band they span.

    A load stuck at rest is held by its friction ``F`` with ``|F| <= F_c + F_s`` (the
    static level of ``[friction]``), which acts on the loop as a load torque ``T_l - F``:
    the rests of the loop with friction are those of the loop without it under every
    load torque in ``[T_l - F_c - F_s, T_l + F_c + F_s]``, a set, not a point.  Its ends
    are :func:`rest_points` at the two extreme load torques; the band of each state of
    :data:`BAND_STATES` the loop has is their span (a P position loop rests anywhere
    within ``+-(F_c + F_s) / (kp kv)`` of its reference; with integral action the
    position rests at the reference, and the twist spans ``+-(F_c + F_s) / k``).

    Parameters
    ----------
    rig : Rig
        With ``[friction]`` on the load side (the motor side's friction is not a load
        torque and gives no band here).
    model : BacklashModel
    pade_order : int

    Returns
    -------
    dict
        ``{state name: (low, high)}`` (rad) of the states whose band has a width (more
        than 1e-9 of its values or of the gap: round-off is no band); empty without load
        friction or where an end has no rest.
    """
    static = rig.friction.coulomb_load + rig.friction.breakaway_load
    if static == 0.0:
        return {}
    part = drive_loop(rig, dry_friction=True).linear_part()
    ends = [rest_points(part, model, [0.0, rig.load.torque + sign * static], pade_order)[0] for sign in (-1.0, 1.0)]
    if not all(ends):
        return {}
    band = {}
    for name in (name for name in BAND_STATES if name in part.state_names):
        values = [rest.state[part.state_names.index(name)] for rests in ends for rest in rests]
        # a width of round-off (a position held at its reference by integral action) is no band
        if max(values) - min(values) > _BAND_RESOLUTION * max(max(map(abs, values)), rig.plant.half_gap):
            band[name] = (float(min(values)), float(max(values)))
    return band
