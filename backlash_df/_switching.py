"""The loop as the compiled kernels and the orbits step it: its modes' matrices, the torque command's modes.

Private to the package (its names are plain because the simulation kernels, the orbits
and :mod:`backlash_df.system` share them; none is public API).  On a
:class:`~backlash_df.system.LinearPart` closed through a piecewise-affine law:

* :func:`mode_matrices`: the augmented matrices of the left-contact, free and
  right-contact modes; with a torque limit (:class:`~backlash_df.system.Command`),
  :func:`command_matrices` splits each into the command's modes of
  :data:`COMMAND_MODES` (linear, saturated, integrator clamped, sliding on the limit)
  and :func:`command_mode_of` says which a state is in;
* :func:`exp_ladder`: the dyadic ladder ``exp(M dt 2^-j)`` that steps and locates
  events inside one mode;
* :class:`KernelArrays`: a linear part as the RK4 kernel takes it, :class:`StickRows` its
  sticking friction (:class:`~backlash_df.system.Sticking`).

The augmented state of :func:`mode_matrices` is ``q = [z, theta_b, 1, chains]``: the
loop's ``n`` states ``z``, then at ``n + THETA_B`` the exact model's theta_b, at
``n + UNIT`` the constant 1, and from ``n + CHAINS`` one chain of ``CHAIN`` states
(an input's value, rate and curvature at ``VALUE``, ``RATE``, ``CURVATURE`` within it)
per varying input, then per delayed signal.  numba folds these module-level integers
into the compiled code.
"""

from typing import NamedTuple

import numpy as np

from ._jit import jit as _jit
from ._laws import DEAD_ZONE, EXACT

__all__ = [
    "THETA_B",
    "UNIT",
    "CHAINS",
    "CHAIN",
    "VALUE",
    "RATE",
    "CURVATURE",
    "KernelArrays",
    "StickRows",
    "mode_matrices",
    "COMMAND_MODES",
    "command_index",
    "augmented_row",
    "CommandMatrices",
    "command_matrices",
    "command_mode_of",
    "initial_command_mode",
    "rubbing_matrix",
    "holding_rows",
    "exp_ladder",
]

_TERMS = 25  # Taylor terms of exp_ladder at most (A0^0 .. A0^24)

#: Offsets past the loop's ``n`` states in the augmented state (module docs): theta_b, the constant 1,
#: the first chain.
THETA_B, UNIT, CHAINS = 0, 1, 2
#: States of a chain, and their order in it: value, rate, curvature of an input over a step.
CHAIN = 3
VALUE, RATE, CURVATURE = range(CHAIN)


class KernelArrays(NamedTuple):
    """A :class:`~backlash_df.system.LinearPart`'s matrices and friction constants as the RK4 kernel takes them
    (:meth:`~backlash_df.system.LinearPart.kernel_arrays`; the attributes' meanings are the linear part's)."""

    A: np.ndarray
    b: np.ndarray
    E: np.ndarray
    c_x: np.ndarray
    c_v: np.ndarray
    d: np.ndarray
    e_d: np.ndarray
    delay: float
    f: np.ndarray
    e_f: np.ndarray
    friction: float
    friction_speed: float
    breakaway: float
    breakaway_speed: float


class StickRows(NamedTuple):
    """A :class:`~backlash_df.system.Sticking` as the RK4 kernel takes it (the attributes' meanings are its)."""

    index: np.ndarray
    column: np.ndarray
    coulomb: np.ndarray
    breakaway: np.ndarray
    stribeck_speed: np.ndarray


def mode_matrices(system, model, law, varying=(), constant=None):
    """Augmented state matrices of the left-contact, free and right-contact modes of a piecewise-affine law.

    State ``[z, theta_b, 1, (w_j, dw_j/dt, d2w_j/dt2) for the inputs j in
    varying and the delayed signal]`` (the layout of the module docs): in contact ``T = k (theta_d -+ alpha) +
    c dtheta_d`` (``c = 0`` for the dead-zone (24)); free, ``T = 0`` and, for
    the exact model, ``dtheta_b/dt = (k / c) (theta_d - theta_b) + dtheta_d``
    (12), (14).  Inputs are quadratic in time over a step (chains of
    integrators); those constant over the run (values ``constant``, the other
    channels) enter with the state ``1``.

    Parameters
    ----------
    system : LinearPart
    model : BacklashModel
        Shaft parameters k, c, alpha.
    law : int
        Law code (:data:`backlash_df._laws.LAW_CODES`) the modes follow: the
        dead-zone (24) contacts without damping, the exact model adds theta_b.
    varying : sequence of int
        Input channels that vary over the run (quadratic over a step).
    constant : array_like, optional
        Values of the other channels (default zero).

    Returns
    -------
    ndarray, shape (3, N, N)
        ``N = n + CHAINS + CHAIN (len(varying) + k)`` for ``k`` delayed signals.
    """
    n = system.A.shape[0]
    varying = list(varying)
    constant = np.zeros(system.E.shape[1] - len(varying)) if constant is None else np.asarray(constant, dtype=float)
    columns = [system.E[:, j] for j in varying] + list(system.e_d.T)
    size = n + CHAINS + CHAIN * len(columns)
    k, c, alpha = model.stiffness, model.damping, model.half_gap
    fixed = np.delete(system.E, varying, axis=1) @ constant
    out = np.zeros((3, size, size))
    for m_aug, side in zip(out, (-1, 0, 1)):
        m_aug[:n, :n] = system.A
        m_aug[:n, n + UNIT] = fixed
        if side:
            damping = 0.0 if law == DEAD_ZONE else c
            m_aug[:n, :n] += np.outer(system.b, k * system.c_x + damping * system.c_v)
            m_aug[:n, n + UNIT] -= system.b * k * side * alpha
        elif law == EXACT:
            m_aug[n + THETA_B, :n] = k / c * system.c_x + system.c_v
            m_aug[n + THETA_B, n + THETA_B] = -k / c
        for j, column in enumerate(columns):
            base = n + CHAINS + CHAIN * j
            m_aug[:n, base + VALUE] = column
            m_aug[base + VALUE, base + RATE] = m_aug[base + RATE, base + CURVATURE] = 1.0
    return out


#: Command modes of a loop with a torque limit, in the order of :func:`command_matrices`' second axis:
#: 0 linear; +-1 saturated at +-limit with the integrator integrating (``e`` not of the sign of ``u``);
#: +-2 saturated, the integrator clamped; +-3 sliding on the limit (``u = +-limit`` held).
COMMAND_MODES = (0, 1, -1, 2, -2, 3, -3)


@_jit
def command_index(mode):
    """Position of a command mode in :data:`COMMAND_MODES`."""
    return 0 if mode == 0 else 2 * abs(mode) - 1 + (1 if mode < 0 else 0)


def augmented_row(system, row, varying=(), constant=None):
    """A row over ``[z, w, u_d]`` as a row over the augmented state of :func:`mode_matrices`.

    Constant inputs (values ``constant``) fold into the state ``1``; a varying
    input and a delayed signal are read from the value state of their chain.
    """
    n, m = system.A.shape[0], system.E.shape[1]
    varying = list(varying)
    others = [j for j in range(m) if j not in varying]
    constant = np.zeros(len(others)) if constant is None else np.asarray(constant, dtype=float)
    size = n + CHAINS + CHAIN * (len(varying) + system.n_delayed)
    out = np.zeros(size)
    out[:n] = row[:n]
    out[n + UNIT] = row[n + np.array(others, dtype=int)] @ constant if others else 0.0
    for i, j in enumerate(varying):
        out[n + CHAINS + CHAIN * i + VALUE] = row[n + j]
    for j in range(system.n_delayed):
        out[n + CHAINS + CHAIN * (len(varying) + j) + VALUE] = row[n + m + j]
    return out


class CommandMatrices(NamedTuple):
    """What :func:`command_matrices` returns (its docs)."""

    per_mode: np.ndarray
    u_row: np.ndarray
    e_row: np.ndarray
    rates: np.ndarray


def command_matrices(system, matrices, varying=(), constant=None):
    """The per-mode matrices of a loop with a torque limit, and the rows its command modes switch on.

    From the backlash modes' matrices of :func:`mode_matrices` (the command
    unsaturated), the command modes of :data:`COMMAND_MODES`: saturated, ``u``'s
    term replaced by ``+-limit``; clamped, the integrator's row zero; sliding, the
    integrator's row holding ``du/dt = 0``.

    Parameters
    ----------
    system : LinearPart
        With a :class:`~backlash_df.system.Command`.
    matrices : ndarray, shape (3, N, N)
        :func:`mode_matrices` of the same ``varying`` and ``constant``.

    Returns
    -------
    CommandMatrices
        A named tuple of:
    per_mode : ndarray, shape (3, 7, N, N)
        Backlash mode (left contact, free, right contact) by command mode.
    u_row, e_row : ndarray, shape (N,)
        The command ``u`` and the speed error ``e`` over the augmented state.
    rates : ndarray, shape (3, 2, 2, N)
        Per backlash mode and side (``+limit``, ``-limit``): the rows of ``du/dt``
        with the integrator clamped and with it integrating, saturated.
    """
    command = system.command
    n = system.A.shape[0]
    u_row = augmented_row(system, command.row, varying, constant)
    e_row = augmented_row(system, command.error, varying, constant)
    size = matrices.shape[1]
    column = np.zeros(size)
    column[:n] = command.column
    per_mode = np.zeros((3, len(COMMAND_MODES), size, size))
    rates = np.zeros((3, 2, 2, size))
    integrator = command.integrator
    for b, base in enumerate(matrices):
        per_mode[b, 0] = base
        for side in (1, -1):
            saturated = base - np.outer(column, u_row)
            saturated[:, n + UNIT] += column * side * command.limit
            per_mode[b, command_index(side)] = saturated
            if integrator < 0:
                continue
            clamped = saturated.copy()
            clamped[integrator] = 0.0
            sliding = clamped.copy()
            sliding[integrator] = -(u_row @ clamped) / u_row[integrator]
            per_mode[b, command_index(2 * side)] = clamped
            per_mode[b, command_index(3 * side)] = sliding
            rates[b, 0 if side > 0 else 1] = (u_row @ clamped, u_row @ saturated)
    return CommandMatrices(per_mode, u_row, e_row, rates)


@_jit
def command_mode_of(mode, u, e, rate_clamped, rate_integrating, limit, clamps):
    """The command mode of a state reached in ``mode`` (module :data:`COMMAND_MODES`).

    ``u`` and ``e`` are the command and the error there, ``rate_clamped`` and
    ``rate_integrating`` ``du/dt`` saturated with the integrator clamped and
    integrating, on the side of ``mode`` (on the side ``u`` crossed from the linear
    mode); ``clamps``: the loop has a clamped integrator.
    """
    if mode == 0:
        side = 1 if u > limit else (-1 if u < -limit else 0)
        if side == 0:
            return 0
        if not clamps or side * e <= 0.0:
            return side
        return 2 * side if side * rate_clamped >= 0.0 else 3 * side
    side = 1 if mode > 0 else -1
    kind = abs(mode)
    if kind == 1:
        if side * u < limit:
            return 0
        return 2 * side if clamps and side * e > 0.0 else mode
    if kind == 2:
        if side * e <= 0.0:
            return side
        if side * u < limit:
            return 3 * side if side * rate_integrating > 0.0 else 0
        return mode
    if side * rate_clamped > 0.0:
        return 2 * side
    return 0 if side * rate_integrating < 0.0 else mode


@_jit
def initial_command_mode(u, e, limit, clamps):
    """The command mode of a state that no event reached (a run's start, an orbit's section point).

    Linear inside the limit; beyond it saturated, with the integrator clamped where
    ``e`` has the sign of ``u``.  Never sliding: off the limit, the clamped flow
    brings ``u`` back onto it first, and :func:`command_mode_of` decides at that event
    (a slide holds ``u``, so one begun beyond the limit would stay there).
    """
    side = 1 if u > limit else (-1 if u < -limit else 0)
    if side == 0:
        return 0
    return 2 * side if clamps and side * e > 0.0 else side


def _taylor(a0, ratios, scaled):
    """``sum_k r^k A0^k / k!`` at every ratio ``r``, shape (ratios, N, N); ``||A0||_1 = scaled <= 1/2``.

    A ratio's terms stop before the first below 1e-18 (its coefficient times
    ``scaled^k``, ``k < 25``); the coefficients are the running products ``r/1 r/2
    ... r/k`` and the terms are added in order of ``k``.
    """
    coefs = np.cumprod(ratios[:, None] / np.arange(1, _TERMS), axis=1)
    kept = np.logical_and.accumulate(coefs * scaled ** np.arange(1, _TERMS) >= 1e-18, axis=1)
    coefs = np.where(kept, coefs, 0.0)
    power = np.eye(a0.shape[0])
    out = np.repeat(power[None], ratios.size, axis=0)
    for k in range(1, 1 + kept.sum(axis=1).max()):
        power = a0 if k == 1 else power @ a0
        out += coefs[:, k - 1, None, None] * power
    return out


def rubbing_matrix(m_aug, columns, index, levels, directions, unit):
    """A mode's augmented matrix with the Coulomb friction of its rubbing sides in their modes.

    A side ``s`` sliding in the direction ``directions[s]`` (+-1) adds ``-direction F_c
    column`` to the constant term (column ``unit`` of ``m_aug``); a stuck side (0) holds
    ``dw/dt = 0``: the field is projected by ``P = I - column e_i^T / column_i``, the
    friction taking the value :func:`holding_rows` gives, that keeps the side at rest
    (Karnopp).  Each side's column is zero at the other sides' speeds, so the projections
    commute.

    Parameters
    ----------
    m_aug : ndarray, shape (N, N)
        The frictionless mode's augmented matrix.
    columns : ndarray, shape (sides, N)
        How each side's friction enters (``-column F``), over the augmented state.
    index : sequence of int
        Each side's speed in the augmented state.
    levels : sequence of float
        Coulomb levels F_c, N m.
    directions : sequence of int
        Each side's mode: +1, -1 sliding that way, 0 stuck.
    unit : int
        The constant 1's column.

    Returns
    -------
    ndarray, shape (N, N)
    """
    rubbing = m_aug.copy()
    for level, column, direction in zip(levels, columns, directions):
        rubbing[:, unit] -= direction * level * column
    for i, column, direction in zip(index, columns, directions):
        if direction == 0:
            rubbing -= np.outer(column / column[i], rubbing[i])
    return rubbing


def holding_rows(m_aug, columns, index):
    """Each rubbing side's holding friction in a frictionless mode, rows over the augmented state (N m).

    ``e_i^T M / column_i``: what the field would accelerate the side by, as a torque; the
    friction that keeps the side at rest (the other sides' friction does not reach its speed).

    Returns
    -------
    ndarray, shape (sides, N)
    """
    return np.array([m_aug[i] / columns[s, i] for s, i in enumerate(index)])


def exp_ladder(m_aug, dt, levels):
    """``exp(M dt 2^-j)`` for ``j = 0 .. levels - 1``, shape (levels, N, N).

    Scaling and squaring: Taylor series of ``A0 = M dt 2^-j0`` (``||A0||_1 <=
    1/2``) at the levels ``j >= j0``, repeated squaring of level ``j0`` above.
    numpy, not compiled: a ladder is built once per mode and step, and compiling it
    cost two seconds of a first ``predict``.
    """
    norm = float(np.max(np.abs(m_aug).sum(axis=0) * dt))
    base = 0
    while norm * 0.5**base > 0.5:
        base += 1
    taylor = _taylor(m_aug * (dt * 0.5**base), 0.5 ** np.append(np.arange(levels - base), 0.0), norm * 0.5**base)
    out = np.empty((levels,) + m_aug.shape)
    out[base:] = taylor[:-1]
    square = taylor[-1]
    for j in range(base - 1, -1, -1):
        square = square @ square
        if j < levels:
            out[j] = square
    return out
