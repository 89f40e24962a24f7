"""The loop's other nonlinearities by their describing functions, slaved to the backlash's cycle.

A loop with a torque limit or dry friction beside its backlash is solved by Gelb and
Vander Velde's multiple-nonlinearity method: for ``theta_d = A sin(w t)`` each further
nonlinearity is replaced by its describing function at the first-harmonic amplitude
of its own input, and that amplitude follows from the loop with those describing
functions in it, a fixed point at every (A, w).  Each class here is that fixed point
for one combination, callable as ``G(jw)`` at (A, w) for the harmonic balance of
:func:`~backlash_df.limit_cycles.predict_limit_cycles`:

* :class:`CommandSlaving`: a torque limit, the saturation's real gain ``N_s`` of the
  command's amplitude ``U``, on every root (branch) of its fixed point;
* :class:`FrictionSlaving`: dry friction on one side, a damper ``N_f`` of the side's
  speed amplitude ``A_w``;
* :class:`FrictionPairSlaving`: dry friction on both sides, two such dampers;
* :class:`CommandFrictionSlaving`: both, the damper solved inside the saturation's
  fixed point.

Every one follows from the loop's responses at a frequency with its nonlinearities
cut (:func:`~backlash_df.system.command_channels`,
:func:`~backlash_df.system.command_friction_channels`,
:func:`~backlash_df.system.friction_channels`): closing them through real
gains is a rank-one or rank-two change, a few complex numbers a frequency.
"""

import dataclasses
import functools
import math

import numpy as np

from .describing import friction_describing_function
from .system import command_channels, command_friction_channels, friction_channels

__all__ = ["CommandSlaving", "FrictionSlaving", "FrictionPairSlaving", "CommandFrictionSlaving"]


@dataclasses.dataclass(frozen=True, eq=False)
class CommandSlaving:
    """A torque-limited loop's linear part with the saturation by its describing function, slaved to A.

    For ``theta_d = A sin(w t)`` the command's first harmonic is ``U(N_s) = A |u / theta_d|``
    (N m) of the loop whose command gain is the saturation's describing function ``N_s``
    (:func:`~backlash_df.describing.saturation_describing_function`), and the gain must be
    the saturation's at that amplitude: ``N_s = N_sat(U(N_s))`` (Gelb and Vander Velde's
    multiple-nonlinearity method).  That fixed point can have several roots in (0, 1]:
    the unsaturated ``N_s = 1`` where ``U(1)`` is inside the limit, and saturated ones
    (``U`` beyond the limit) where ``U`` grows as ``N_s`` falls: on a near-rigid shaft
    ``theta_d`` nearly vanishes at the gain of the rigid loop's own saturation cycle, and
    ``U`` peaks there.  :meth:`roots` finds them all.  Each is a *branch*, numbered from the
    top (branch 0 the largest ``N_s``; where the command stays inside the limit, the only
    one, ``N_s = 1``); calling the object with ``branch=k`` gives ``G(jw)`` of the loop with
    the k-th root's gain, NaN where (A, w) has fewer roots.  All of it follows from the
    loop's responses with the command cut (:func:`~backlash_df.system.command_channels`:
    linear-fractional in the gain), one solve per frequency.

    Attributes
    ----------
    part : LinearPart
        The loop, with its :class:`~backlash_df.system.Command`.

    Notes
    -----
    With ``theta(N) = a (1 - d N) + b c N = a + e N`` (``e = b c - a d``; ``theta_d`` per
    unit shaft torque), ``U(N) = A |c| / |theta(N)|`` and ``|theta|^2`` is a quadratic in N:
    ``U`` rises to one peak at ``N* = -Re(a e*) / |e|^2`` and falls beyond it, so that
    ``h(N) = N - N_sat(U(N))`` increases below the peak (at most one root there).  The
    roots are sought on a grid fixed in ``log U``: ``_ROOT_GRID`` levels from the limit to
    the peak (at most ``_U_SPAN`` times the limit), each mapped to the N on either side of
    the peak that gives it, with 0, ``N*`` (clipped to [0, 1]) and 1 added: the grid
    resolves the peak however narrow it is.  Neighbours on which ``h > 0`` against
    ``h <= 0`` differ are bisected ``_BISECTIONS`` times in N, ``h`` evaluated directly, so
    each root substitutes back to round-off.  Two roots above the peak closer than the
    grid's step (a factor ``_U_SPAN ** (1 / (_ROOT_GRID - 1))``, 1.8, in ``U``) pass unseen,
    as do roots below ``N_s = 4 / (pi _U_SPAN)``; roots within ``_ROOT_TOL`` of each other
    count as one.
    """

    part: object

    _BISECTIONS = 60
    _ROOT_GRID = 48
    _U_SPAN = 1e12
    _ROOT_TOL = 1e-12

    @staticmethod
    def closed(channels, gain):
        """(G, u / theta_d) of the loop with the command through ``gain``, from its
        :func:`~backlash_df.system.command_channels`: rad/(N m) and N m/rad, broadcast."""
        a, b, c, d = channels
        theta = a * (1.0 - d * gain) + b * c * gain
        with np.errstate(divide="ignore", invalid="ignore"):  # NaN off a branch
            return -theta / (1.0 - d * gain), c / theta

    def channels(self, omega):
        """The loop's :func:`~backlash_df.system.command_channels` at the frequencies ``omega``."""
        return command_channels(self.part, omega)

    def response(self, amplitude, channels, gain):
        """G(jw) at (A, w) on the branch whose gain is ``gain``, from the loop's :meth:`channels`."""
        return self._closed_at(amplitude, channels, gain)[0]

    def branch_roots(self, amplitude, channels):
        """:meth:`roots` from the loop's :func:`~backlash_df.system.command_channels` (class notes).

        Parameters
        ----------
        amplitude : array_like
            A, rad.
        channels : tuple of ndarray
            ``(a, b, c, d)`` at the frequencies, broadcast against ``amplitude``.

        Returns
        -------
        ndarray
            The roots by decreasing N_s on a last axis of at least one entry, NaN-padded.
        """
        amplitude, a, b, c, d = np.broadcast_arrays(np.asarray(amplitude, dtype=float), *channels)
        e = b * c - a * d
        scale = amplitude * np.abs(c)
        columns = tuple(x.reshape(-1) for x in (a.real, a.imag, e.real, e.imag, scale / self.part.command.limit))
        return self._gain_roots(a, e, scale, columns, _saturation_excess)

    def _gain_roots(self, a, e, scale, columns, excess):
        """The roots of ``excess(columns, N) = 0`` for N in (0, 1] on the grid the linear-fractional ``U(N) = scale /
        |a + e N|`` fixes (class notes), narrowed on ``excess`` itself (:meth:`_refine`), by point.

        ``excess(fixed, n)`` is ``N - N_sat(U(N))`` with ``fixed`` the ``columns`` (one entry per point, flat) of
        the points asked for, broadcast against ``n``; where it is the saturation's of ``U(N)`` itself
        (:meth:`branch_roots`) the roots are this class's, and N = 1 is a root wherever ``U(1)`` is inside the
        limit.  Returns the roots by decreasing N on a last axis after the shape of ``a``, NaN-padded.
        """
        limit = self.part.command.limit
        shape = a.shape
        a, e, scale = (x.reshape(-1) for x in (a, e, scale))
        star, peak = _peak(a, e)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            top = scale / np.abs(a + e * peak)  # the largest U on [0, 1]
            unsaturated = scale / np.abs(a + e) <= limit
        busy = np.flatnonzero(top > limit)  # elsewhere N_sat(U) = 1 on [0, 1]: N_s = 1 alone
        if not busy.size:
            return np.where(unsaturated, 1.0, np.nan).reshape(shape + (1,))
        a, e, scale, star, peak = (x[busy] for x in (a, e, scale, star, peak))
        top = np.minimum(top[busy], self._U_SPAN * limit)
        columns = tuple(x[busy] for x in columns)
        every = tuple(x[:, None] for x in columns)
        levels = limit * (top / limit)[:, None] ** np.linspace(0.0, 1.0, self._ROOT_GRID)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            floor = np.abs(a + e * star) ** 2  # the least |a + e N|^2
            offset = np.sqrt(np.maximum((scale[:, None] / levels) ** 2 - floor[:, None], 0.0)) / np.abs(e)[:, None]
            grid = np.concatenate([np.clip(star[:, None] - offset, 0.0, peak[:, None]),
                                   np.clip(star[:, None] + offset, peak[:, None], 1.0),
                                   np.stack([np.zeros(busy.size), peak, np.ones(busy.size)], axis=1)], axis=1)
        grid = np.sort(np.where(np.isfinite(grid), grid, 0.0), axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            values = excess(every, grid)
        positive = values > 0.0
        row, col = np.nonzero(positive[:, 1:] != positive[:, :-1])
        brackets = tuple(x[row] for x in columns)
        with np.errstate(divide="ignore", invalid="ignore"):
            lo, hi = self._refine(functools.partial(excess, brackets), grid[row, col], grid[row, col + 1],
                                  values[row, col], values[row, col + 1])
        flat_unsaturated = np.flatnonzero(unsaturated)
        points = np.concatenate([busy[row], flat_unsaturated])
        values = np.concatenate([0.5 * (lo + hi), np.ones(flat_unsaturated.size)])
        order = np.lexsort((-values, points))
        points, values = points[order], values[order]
        keep = np.ones(points.size, dtype=bool)  # a root within _ROOT_TOL of the one above it is that one
        keep[1:] = (points[1:] != points[:-1]) | (values[:-1] - values[1:] > self._ROOT_TOL)
        points, values = points[keep], values[keep]
        first = np.searchsorted(points, points)  # the index of each point's first root
        rank = np.arange(points.size) - first
        roots = np.full((math.prod(shape), max(1, int(rank.max(initial=0)) + 1)), np.nan)
        roots[points, rank] = values
        return roots.reshape(shape + (roots.shape[1],))

    def _refine(self, excess, lo, hi, at_lo, at_hi):
        """The brackets ``[lo, hi]`` of the roots of ``excess`` (its values there ``at_lo``, ``at_hi``, of opposite
        signs) bisected down to neighbouring floats (at most ``_BISECTIONS`` times), ``excess`` evaluated
        directly: each root substitutes back to round-off."""
        rising = at_hi > 0.0
        for _ in range(self._BISECTIONS):
            mid = 0.5 * (lo + hi)
            if not ((mid > lo) & (mid < hi)).any():  # every bracket down to neighbouring floats
                break
            upper = (excess(mid) > 0.0) == rising  # mid on the upper end's side
            lo, hi = np.where(upper, lo, mid), np.where(upper, mid, hi)
        return lo, hi

    def roots(self, amplitude, omega):
        """Every root of ``N_s = N_sat(U(N_s))`` in (0, 1] at (A, w), broadcast.

        Parameters
        ----------
        amplitude : array_like
            A, rad.
        omega : array_like
            w, rad/s.

        Returns
        -------
        ndarray
            The broadcast shape of A and w with a last axis of at least one entry: the roots by
            decreasing N_s (the branches), NaN beyond the roots of each (A, w).
        """
        return self.branch_roots(amplitude, self.channels(omega))

    def gain(self, amplitude, omega, branch=0):
        """N_s of branch ``branch`` at (A, w), broadcast: 1 where the command stays inside the limit, NaN where
        (A, w) has no such root."""
        return self._branch(self.roots(amplitude, omega), branch)

    @staticmethod
    def _branch(roots, branch):
        return roots[..., branch] if branch < roots.shape[-1] else np.full(roots.shape[:-1], np.nan)

    def _closed_at(self, amplitude, channels, gain):
        """(G, u / theta_d) at (A, w) with the command through ``gain``: :meth:`closed` (A matters only to a
        further slaved nonlinearity, :class:`CommandFrictionSlaving`)."""
        return self.closed(channels, gain)

    def least_amplitude(self, omega):
        """A, rad: the amplitude above which a saturated root exists at w (the peak of ``U`` over the gain
        reaches the limit: ``L min |theta(N)| / |c|``, N in [0, 1]), broadcast."""
        a, b, c, d = command_channels(self.part, omega)
        e = b * c - a * d
        return self.part.command.limit * np.abs(a + e * _peak(a, e)[1]) / np.abs(c)

    def command_amplitude(self, amplitude, omega, branch=0):
        """U, N m: the first-harmonic amplitude of the command u at (A, w) on branch ``branch``."""
        channels = self.channels(omega)
        gain = self._branch(self.branch_roots(amplitude, channels), branch)
        return np.asarray(amplitude) * np.abs(self._closed_at(amplitude, channels, gain)[1])

    def __call__(self, omega, amplitude=None, branch=0):
        """G(jw), rad/(N m), with the saturation's gain at A on branch ``branch`` (without ``amplitude``: the
        command unsaturated, and no further slaved nonlinearity), broadcast."""
        channels = self.channels(omega)
        if amplitude is None:
            return self._unslaved(channels)
        return self.response(amplitude, channels, self._branch(self.branch_roots(amplitude, channels), branch))

    def _unslaved(self, channels):
        """G(jw) with the command unsaturated."""
        return self.closed(channels, 1.0)[0]

    def sticks(self, amplitude, omega, branch=0):
        """Whether a rubbing side sticks through the cycle at (A, w): never, the loop has no dry friction."""
        return np.zeros(np.broadcast_shapes(np.shape(amplitude), np.shape(omega)), dtype=bool)

    def speed_amplitudes(self, amplitude, omega, branch=0):
        """{side: A_w} of the rubbing sides: none, the loop has no dry friction."""
        return {}


def _peak(a, e):
    """``(N*, peak)``: where ``|a + e N|`` is least over real N, and that point clipped to [0, 1] (0 where N* is not a
    number): the peak of ``U(N) = scale / |a + e N|`` (:class:`CommandSlaving`'s notes), broadcast."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        star = -(a * np.conj(e)).real / np.abs(e) ** 2
    return star, np.where(np.isfinite(star), np.clip(star, 0.0, 1.0), 0.0)


def _saturation_excess(fixed, n):
    """h(N) = N - N_sat(U(N)) (:func:`~backlash_df.describing.saturation_describing_function` written out: the
    bisection's kernel), ``fixed`` the ``(Re a, Im a, Re e, Im e, scale / limit)`` broadcast against ``n``."""
    a_re, a_im, e_re, e_im, reach = fixed
    return n - _saturation_gain(np.hypot(a_re + e_re * n, a_im + e_im * n) / reach)


def _saturation_gain(ratio):
    """N_sat at ``limit / U = ratio`` (clipped to 1: inside the limit)."""
    r = np.minimum(ratio, 1.0)
    return 2.0 / np.pi * (np.arcsin(r) + r * np.sqrt(1.0 - r * r))


@dataclasses.dataclass(frozen=True, eq=False)
class FrictionSlaving:
    """A loop with dry friction on one side, the friction by its describing function, slaved to A.

    The friction's describing function is a viscous coefficient ``N_f(A_w)``
    (:func:`~backlash_df.describing.friction_describing_function`) of the side's speed
    amplitude ``A_w``, and for ``theta_d = A sin(w t)`` that amplitude is
    ``A |z_i / theta_d|`` of the loop with the damper ``N_f`` on the side (Gelb and
    Vander Velde's multiple-nonlinearity method, as :class:`CommandSlaving` does for a
    torque limit).  :meth:`gain` solves ``d = N_f(A_w(d))``: with Coulomb friction
    alone in closed form (the damper changes the loop by a rank one,
    :meth:`_channels`), with a breakaway friction by false position: ``d -
    N_f(A_w(d))`` is negative at ``d = 0`` and positive beyond the root, found by
    doubling (:func:`_friction_damper`, :func:`_false_position`).  Where there is no root (with a breakaway friction:
    none below ``2^50`` times the first guess) the friction holds the side through the
    cycle (the driving torque's amplitude is below the friction's): the side
    **sticks**, the damper is ``2^51`` times the friction's at ``d = 0`` (the side
    locked), and :meth:`sticks` says so: the describing function of a sliding side
    does not hold.

    Attributes
    ----------
    part : LinearPart
        The loop, with a :class:`~backlash_df.system.Sticking` of one side.
    """

    part: object

    def _channels(self, omega):
        """The loop's responses without the damper, from which those with any damper follow, broadcast.

        The damper ``d`` on the side's speed ``z_i`` adds ``d column e_i^T`` to ``jw I - A``
        (the dead time exact): a rank-one change.  From ``z = M^-1 b`` and ``y = M^-1 column``
        of the loop without it, the Sherman-Morrison formula gives ``z_i(d) = z_i / (1 + d y_i)``
        and ``theta_d(d) = c z - d z_i (c y) / (1 + d y_i)``: every damper's responses from
        the four numbers ``(c z, c y, z_i, y_i)``, one solve a frequency (:func:`_damped`).
        """
        return _block(friction_channels(self.part, omega), 1)

    def _solve(self, amplitude, omega):
        """(d, sticks, channels): :func:`_friction_damper` at the broadcast (A, w), with the loop's
        :meth:`_channels` there."""
        a, w = np.broadcast_arrays(np.asarray(amplitude, dtype=float), np.asarray(omega, dtype=float))
        channels = self._channels(w)
        return (*_friction_damper(a, channels, self.part.sticking), channels)

    def gain(self, amplitude, omega):
        """The friction's equivalent damping N_f at (A, w), N m s/rad, broadcast."""
        return self._solve(amplitude, omega)[0]

    def sticks(self, amplitude, omega):
        """Whether the side sticks through the cycle at (A, w): the friction's DF has no fixed point."""
        return self._solve(amplitude, omega)[1]

    def speed_amplitudes(self, amplitude, omega):
        """{side: A_w}, rad/s: the first-harmonic amplitude of the rubbing side's speed at (A, w)."""
        damping, _, channels = self._solve(amplitude, omega)
        return {self.part.sticking.names[0]: np.asarray(amplitude) * np.abs(_damped(channels, damping)[1])}

    def __call__(self, omega, amplitude=None):
        """G(jw) with the friction's damper at A (without ``amplitude``: the loop without its dry friction)."""
        if amplitude is None:
            return -self._channels(omega)[0]
        damping, _, channels = self._solve(amplitude, omega)
        return _damped(channels, damping)[0]


@dataclasses.dataclass(frozen=True, eq=False)
class FrictionPairSlaving:
    """A loop with dry friction on both sides, each by its describing function, both slaved to A.

    Each side's friction is a damper ``d_s = N_f(A_w,s)`` of its own speed amplitude in the
    loop with both dampers in it (Gelb and Vander Velde's multiple-nonlinearity method, as
    :class:`FrictionSlaving` for one side).  For a given load damper ``d_2`` the motor's
    fixed point ``d_1(d_2)`` is :class:`FrictionSlaving`'s in the loop with ``d_2`` closed
    (:func:`_friction_damper`: in closed form for Coulomb friction); what is left is one
    equation, ``d_2 = N_f(A_w,2(d_1(d_2), d_2))``, bracketed by doubling and narrowed by
    false position (:func:`_fixed_point`).  Both closings are rank-one changes of the
    nine responses of :func:`~backlash_df.system.friction_channels`, one solve a
    frequency.  Where either side has no fixed point (the friction holds it through the
    cycle) it is locked, as in :class:`FrictionSlaving`, and :meth:`sticks` says so.

    Attributes
    ----------
    part : LinearPart
        The loop, with a :class:`~backlash_df.system.Sticking` of two sides.
    """

    part: object

    def _motor(self, amplitude, channels, load):
        """(d_1, sticks_1, channels with both dampers closed) at the load damper ``load``, broadcast."""
        with_load = _close(channels, 2, load)
        damping, sticks = _friction_damper(amplitude, _block(with_load, 1), self.part.sticking, side=0)
        return damping, sticks, _close(with_load, 1, damping)

    def _load_excess(self, amplitude, channels, load):
        """``N_f,2(A_w,2) - d_2`` with the motor's damper at its fixed point: positive below the root."""
        closed = self._motor(amplitude, channels, load)[2]
        return _side_gain(amplitude * np.abs(closed[..., 2, 0] / closed[..., 0, 0]), self.part.sticking, 1) - load

    def _solve(self, amplitude, omega):
        """(the loop's responses with both dampers closed, sticks) at the broadcast (A, w)."""
        a, w = np.broadcast_arrays(np.asarray(amplitude, dtype=float), np.asarray(omega, dtype=float))
        channels = friction_channels(self.part, w)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            excess = functools.partial(self._load_excess, a, channels)
            load, load_sticks = _fixed_point(excess, excess(np.zeros(a.shape)))
            _, motor_sticks, closed = self._motor(a, channels, load)
        return closed, load_sticks | motor_sticks

    def sticks(self, amplitude, omega):
        """Whether a side sticks through the cycle at (A, w): its friction's DF has no fixed point."""
        return self._solve(amplitude, omega)[1]

    def speed_amplitudes(self, amplitude, omega):
        """{side: A_w}, rad/s: the first-harmonic amplitudes of the sides' speeds at (A, w)."""
        closed = self._solve(amplitude, omega)[0]
        return {name: np.asarray(amplitude) * np.abs(closed[..., 1 + s, 0] / closed[..., 0, 0])
                for s, name in enumerate(self.part.sticking.names)}

    def __call__(self, omega, amplitude=None):
        """G(jw) with both dampers at A (without ``amplitude``: the loop without its dry friction)."""
        if amplitude is None:
            return -friction_channels(self.part, omega)[..., 0, 0]
        return -self._solve(amplitude, omega)[0][..., 0, 0]


@dataclasses.dataclass(frozen=True, eq=False)
class CommandFrictionSlaving(CommandSlaving):
    """A torque-limited loop with dry friction on one side: the saturation and the friction both slaved to A.

    The saturation's gain ``N_s`` on the command and the friction's damper ``d`` on the
    side's speed are fixed points together: ``N_s = N_sat(U)`` and ``d = N_f(A_w)``, with
    ``U`` and ``A_w`` of the loop with both in it (Gelb and Vander Velde's
    multiple-nonlinearity method).  For a given ``N_s`` the loop with its command closed
    through it is linear and the damper's fixed point is :class:`FrictionSlaving`'s
    (:func:`_friction_damper`: in closed form for Coulomb friction, by false position with
    a breakaway); what is left is one equation in ``N_s``, ``h(N_s) = N_s -
    N_sat(U(N_s, d(N_s)))``, whose roots are the branches, sought as :class:`CommandSlaving`
    seeks its own, on the grid of the loop with the damper fixed at the unsaturated one's,
    ``d(1)``, and narrowed by false position (:func:`_false_position`, to 1e-13).  With a
    breakaway friction each value of ``h`` is a false position of its own: a prediction
    takes tens of seconds where Coulomb friction's takes one.  ``N_s = 1`` is a root where ``U(1,
    d(1))`` is inside the limit.  Both closings are rank-one changes (:func:`_close`) of
    the nine responses of :func:`~backlash_df.system.command_friction_channels`, one solve
    a frequency.

    A branch where the friction holds the side (no damper's fixed point: the side
    locked, as in :class:`FrictionSlaving`) is solved with the locked side, and
    :meth:`sticks` says so.  The search boxes around a saturated branch's dips
    (:meth:`least_amplitude`) are those of the loop without its friction.

    Attributes
    ----------
    part : LinearPart
        The loop, with its :class:`~backlash_df.system.Command` and a
        :class:`~backlash_df.system.Sticking` of one side.
    """

    def channels(self, omega):
        """The loop's :func:`~backlash_df.system.command_friction_channels` at the frequencies ``omega``."""
        return command_friction_channels(self.part, omega)

    def _solved(self, amplitude, channels, gain):
        """(d, sticks, G, u / theta_d, z_i / theta_d) of the loop with the command through ``gain`` and the
        damper at its fixed point there, broadcast: the command closed first (``T_c = N u``, entering where a
        friction would with the opposite sign: a damper of ``-N``), then the side's friction."""
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            commanded = _close(channels, 1, -np.asarray(gain))
            damping, sticks = _friction_damper(amplitude, _block(commanded, 2), self.part.sticking)
            closed = _close(commanded, 2, damping)
            theta = closed[..., 0, 0]
            return damping, sticks, -theta, closed[..., 1, 0] / theta, closed[..., 2, 0] / theta

    def branch_roots(self, amplitude, channels):
        """The roots of ``h(N_s)`` (class notes) in (0, 1] at the broadcast A and the channels' frequencies.

        Parameters
        ----------
        amplitude : array_like
            A, rad.
        channels : ndarray
            :func:`~backlash_df.system.command_friction_channels`, ``(..., 3, 3)``.

        Returns
        -------
        ndarray
            The roots by decreasing N_s on a last axis of at least one entry, NaN-padded.
        """
        amplitude = np.asarray(amplitude, dtype=float)
        shape = np.broadcast_shapes(amplitude.shape, channels.shape[:-2])
        amplitude = np.broadcast_to(amplitude, shape)
        channels = np.broadcast_to(channels, shape + (3, 3))
        top = self._solved(amplitude, channels, 1.0)[0]  # the unsaturated branch's damper d(1)
        a, b, c, d = _block(_close(channels, 2, top), 1)  # command_channels of the loop with that damper
        e = b * c - a * d
        scale = amplitude * np.abs(c)
        flat = channels.reshape(-1, 3, 3)
        columns = (amplitude.reshape(-1), *(flat[:, o, j] for o in range(3) for j in range(3)))
        return self._gain_roots(a, e, scale, columns, self._excess)

    def _excess(self, fixed, n):
        """h(N) = N - N_sat(U(N, d(N))), ``fixed`` the amplitude and the nine channels (flat) against ``n``."""
        amplitude, *entries = np.broadcast_arrays(*fixed, n)[:-1]
        channels = np.stack(entries, axis=-1).reshape(amplitude.shape + (3, 3))
        command = amplitude * np.abs(self._solved(amplitude, channels, n)[3])
        with np.errstate(divide="ignore", invalid="ignore"):
            return n - _saturation_gain(self.part.command.limit / command)

    def _refine(self, excess, lo, hi, at_lo, at_hi):
        """The brackets of :meth:`CommandSlaving._refine` narrowed by :func:`_false_position`: each value of ``h``
        here solves a damper's fixed point, and bisection to neighbouring floats would take fifty."""
        return _false_position(excess, lo, hi, at_lo, at_hi)

    def _closed_at(self, amplitude, channels, gain):
        solved = self._solved(amplitude, channels, gain)
        return solved[2], solved[3]

    def _unslaved(self, channels):
        """G(jw) with the command unsaturated and no friction."""
        return -_close(channels, 1, -1.0)[..., 0, 0]

    def _at(self, amplitude, omega, branch):
        channels = self.channels(omega)
        gain = self._branch(self.branch_roots(amplitude, channels), branch)
        return self._solved(amplitude, channels, gain)

    def sticks(self, amplitude, omega, branch=0):
        """Whether the side sticks through the cycle at (A, w) on branch ``branch``: no damper's fixed point."""
        return self._at(amplitude, omega, branch)[1]

    def speed_amplitudes(self, amplitude, omega, branch=0):
        """{side: A_w}, rad/s: the first-harmonic amplitude of the rubbing side's speed at (A, w) on branch
        ``branch``."""
        return {self.part.sticking.names[0]: np.asarray(amplitude) * np.abs(self._at(amplitude, omega, branch)[4])}


def _close(channels, k, damping):
    """The responses ``channels`` (outputs by sources, ``(..., m, m)``) with the friction of entry ``k`` (its side's
    speed the k-th output, its column the k-th source) closed through the damper ``damping``, ``F = d z_k``:
    ``R[o, j] - d R[o, k] R[k, j] / (1 + d R[k, k])`` (Sherman-Morrison), broadcast; entry ``k`` stays, the
    side's speed with its damper."""
    d = np.asarray(damping)[..., None, None]
    column, row = channels[..., :, k:k + 1], channels[..., k:k + 1, :]
    return channels - d * column * row / (1.0 + d * channels[..., k:k + 1, k:k + 1])


def _block(channels, k):
    """``(R[0, 0], R[0, k], R[k, 0], R[k, k])``: from ``T`` and from source ``k`` to theta_d and to output ``k``
    (:class:`FrictionSlaving`'s channels of entry k's side; with k the command,
    :func:`~backlash_df.system.command_channels`' ``(a, b, c, d)``)."""
    return channels[..., 0, 0], channels[..., 0, k], channels[..., k, 0], channels[..., k, k]


def _damped(channels, damping):
    """(G, z_i / theta_d) of the loop with the side's dry friction as the viscous ``damping``, broadcast, from
    its :class:`FrictionSlaving` channels ``(theta_z, theta_y, side_z, side_y)``."""
    theta_z, theta_y, side_z, side_y = channels
    spread = 1.0 + damping * side_y
    theta = theta_z - damping * side_z * theta_y / spread
    return -theta, side_z / (theta * spread)


def _friction_excess(amplitude, channels, damping, sticking, side=0):
    """``N_f(A_w(d)) - d``, N m s/rad, of side ``side``: positive below the fixed point."""
    return _side_gain(amplitude * np.abs(_damped(channels, damping)[1]), sticking, side) - damping


def _side_gain(speed, sticking, side):
    """N_f of side ``side``'s friction at its speed amplitude ``speed`` (rad/s; 0 taken as the least positive)."""
    return friction_describing_function(np.maximum(speed, 1e-300), sticking.coulomb[side], sticking.breakaway[side],
                                        sticking.stribeck_speed[side])


def _coulomb_root(amplitude, channels, coulomb):
    """The fixed point of Coulomb friction ``coulomb`` (N m) alone, broadcast; NaN where there is none.

    With ``a = c z`` and ``g = a y_i - z_i c y`` (:meth:`FrictionSlaving._channels`) the
    side's speed amplitude is ``A_w = A |z_i| / |a + d g|``, so ``d = N_f(A_w) = K |a + d
    g|``, ``K = 4 F_c / (pi A |z_i|)``: the smallest root ``d >= 0`` of ``(1 - K^2 |g|^2)
    d^2 - 2 K^2 Re(a g*) d - K^2 |a|^2 = 0``, written so that neither root cancels.
    """
    theta_z, theta_y, side_z, side_y = channels
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # a side at rest: K = inf, no root
        gain = 4.0 * coulomb / (np.pi * np.maximum(amplitude * np.abs(side_z), 1e-300))
        slope = theta_z * side_y - side_z * theta_y
        alpha = 1.0 - (gain * np.abs(slope)) ** 2
        beta = gain ** 2 * (theta_z * np.conj(slope)).real
        gamma = (gain * np.abs(theta_z)) ** 2
        disc = beta ** 2 + alpha * gamma
        root = np.sqrt(np.maximum(disc, 0.0))
        found = (disc >= 0.0) & np.where(beta > 0.0, alpha > 0.0, root > beta)
        return np.where(found, np.where(beta > 0.0, (beta + root) / alpha, gamma / (root - beta)), np.nan)


_DOUBLINGS = 50


def _friction_damper(amplitude, channels, sticking, side=0):
    """(d, sticks): the damper's fixed point ``d = N_f(A_w(d))`` of side ``side`` at the broadcast A and channels,
    and where there is none, the locked side's damper and True (:class:`FrictionSlaving`'s notes)."""
    a = np.broadcast_to(np.asarray(amplitude, dtype=float), np.broadcast_shapes(np.shape(amplitude),
                                                                                 np.shape(channels[0])))
    excess = functools.partial(_friction_excess, a, channels, sticking=sticking, side=side)
    at_rest = excess(np.zeros(a.shape))  # the friction's damper at d = 0
    if sticking.breakaway[side] == 0.0:
        d = _coulomb_root(a, channels, sticking.coulomb[side])
        return np.where(np.isnan(d), 2.0 ** (_DOUBLINGS + 1) * at_rest, d), np.isnan(d)
    return _fixed_point(excess, at_rest)


def _fixed_point(excess, at_rest):
    """(d, sticks): a root ``d > 0`` of ``excess`` (positive below it, ``at_rest`` at d = 0), bracketed by doubling
    ``2 at_rest`` (at most ``_DOUBLINGS`` times) and narrowed by :func:`_false_position`; where the doublings
    find no bracket, the last of them and True (the side locked)."""
    hi = 2.0 * at_rest
    for _ in range(_DOUBLINGS):
        above = excess(hi) > 0.0
        if not above.any():
            break
        hi = np.where(above, 2.0 * hi, hi)
    at_hi = excess(hi)
    sticks = at_hi > 0.0
    lo, hi = _false_position(excess, np.where(sticks, hi, 0.0), hi, at_rest, at_hi)  # a stuck side: lo = hi
    return np.where(sticks, hi, 0.5 * (lo + hi)), sticks


def _false_position(f, lo, hi, at_lo, at_hi, rtol=1e-13, iterations=120):
    """The brackets ``[lo, hi]`` (``f`` there ``at_lo``, ``at_hi``, of opposite signs), narrowed together by the
    Illinois variant of false position (Dowell and Jarratt, 1971) to ``rtol`` of ``hi``, broadcast.

    The end on ``hi``'s side of each new point (``f > 0`` there as at ``hi``) moves to it, the other keeps
    its side; an end kept twice in a row has its value halved (Illinois), so both ends converge,
    superlinearly, in about ten evaluations where bisection takes forty.  A step that is not a number or
    leaves the bracket is a bisection's, and from the twelfth on every other step is one (near the root
    round-off in ``f`` can stall false position).  Where ``|f|`` is within ``rtol`` of the point (``f`` is
    of the size of its argument: a damper's excess, a gain's), both ends meet there.
    """
    rising = at_hi > 0.0
    kept = np.zeros(lo.shape, dtype=np.int8)  # +1: hi kept by the last step, -1: lo kept
    for step in range(iterations):
        active = (hi - lo) > rtol * np.maximum(np.abs(lo), np.abs(hi))
        if not active.any():
            break
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            x = hi - at_hi * (hi - lo) / (at_hi - at_lo)
        mid = 0.5 * (lo + hi)
        x = np.where((x > lo) & (x < hi) & (step < 12 or step % 2 == 0), x, mid)
        value = f(x)
        upper = (value > 0.0) == rising  # x on hi's side: hi moves there
        at_lo = np.where(upper & (kept == -1), 0.5 * at_lo, at_lo)
        at_hi = np.where(~upper & (kept == 1), 0.5 * at_hi, at_hi)
        root = np.abs(value) <= rtol * np.abs(x)  # f's own round-off: both ends meet there
        move_hi, move_lo = active & (upper | root), active & (~upper | root)
        hi, at_hi = np.where(move_hi, x, hi), np.where(move_hi, value, at_hi)
        lo, at_lo = np.where(move_lo, x, lo), np.where(move_lo, value, at_lo)
        kept = np.where(upper, -1, 1).astype(np.int8)
    return lo, hi
