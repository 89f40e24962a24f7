"""The friction law of the effect catalogue: its value and its partial derivatives.

One law for every side of a drive that rubs::

    F(w) = d w + (F_c + F_s exp(-(w / w_s)^2)) tanh(w / eps)

(N m) at the speed ``w`` (rad/s) of the side it acts on, with the viscous
coefficient ``d`` (N m s/rad), the Coulomb level ``F_c`` and the breakaway
(Stribeck) level ``F_s`` (N m, both the size of a torque that opposes the
motion), the smoothing speed ``eps`` of the sign ``tanh(w / eps)`` and the
Stribeck speed ``w_s`` (rad/s, both positive).  The contract page's effect
catalogue names the parameters; a diagnosis chooses ``eps`` and ``w_s`` among
fractions of the record's largest speed (:mod:`backlash_df.identify.effects`).

The law is written once, with numpy's functions: :func:`friction` evaluates it
on arrays, and numba compiles the same text into :func:`friction_kernel`, the
scalar form the compiled kernels inline (the closed-loop simulation's friction
of the driven machine, :mod:`backlash_df.simulation`; the diagnosis' prediction
kernels, :mod:`backlash_df.identify`).  :func:`friction_partials` gives the value
with its derivatives, for the diagnosis' forward sensitivities.

Without Coulomb and breakaway friction no tanh, without breakaway friction no
exp is evaluated: the number is the same (they would be multiplied by zero), at
less cost in a kernel's inner loop.
"""

import math

import numpy as np

from ._jit import inline as _inline

__all__ = ["friction", "friction_kernel", "friction_partials"]


def friction(w, viscous, coulomb, breakaway, eps, w_s):
    """The friction torque ``F(w)`` of the module docs, N m.

    Parameters
    ----------
    w : float or ndarray
        Speed of the rubbing side, rad/s.
    viscous : float
        Viscous coefficient ``d``, N m s/rad.
    coulomb, breakaway : float
        Coulomb level ``F_c`` and breakaway level ``F_s``, N m.
    eps, w_s : float
        Smoothing speed and Stribeck speed, rad/s, positive.

    Returns
    -------
    float or ndarray
        ``F(w)``, N m, of the shape of ``w``.

    See Also
    --------
    friction_kernel : the same law compiled, for numba kernels.

    Examples
    --------
    Far from zero speed the smoothed sign is 1 and the breakaway part has decayed:

    >>> float(friction(2.0, 0.5, 3.0, 4.0, 0.01, 0.05))
    4.0
    >>> friction(np.array([-2.0, 0.0]), 0.5, 3.0, 4.0, 0.01, 0.05)
    array([-4., 0.])
    """
    if coulomb == 0.0 and breakaway == 0.0:
        return viscous * w
    if breakaway == 0.0:
        return viscous * w + coulomb * np.tanh(w / eps)
    return viscous * w + (coulomb + breakaway * np.exp(-(w / w_s) ** 2)) * np.tanh(w / eps)


#: :func:`friction` compiled by numba for a float ``w``, inlined into the kernels that call it.
friction_kernel = _inline(friction)


@_inline
def friction_partials(w, viscous, coulomb, breakaway, eps, w_s, with_tanh=True, with_exp=True):
    """``(F, dF/dw, dF/dcoulomb, dF/dbreakaway)`` of the law (module docs) at a float ``w``, compiled.

    ``F`` is :func:`friction_kernel`'s to the bit (a zero level adds zero); ``dF/dviscous`` is ``w``.
    Without ``with_tanh`` (no Coulomb nor breakaway friction, neither differentiated by) no tanh, without
    ``with_exp`` (no breakaway friction, not differentiated by) no exp is evaluated, as in
    :func:`friction_kernel`; the partial derivatives they would give are then returned as zero.

    Returns
    -------
    tuple of float
        N m, N m s/rad, 1, 1.
    """
    th = math.tanh(w / eps) if with_tanh else 0.0
    e = math.exp(-(w / w_s) ** 2) if with_exp else 0.0
    level = coulomb + breakaway * e
    by_w = viscous + level * (1.0 - th * th) / eps - 2.0 * breakaway * e * th * w / (w_s * w_s)
    return viscous * w + level * th, by_w, th, e * th
