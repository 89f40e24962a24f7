"""Closed-form describing functions of the classical nonlinearities, and python-control's elements.

The elements of the textbooks (Gelb and Vander Velde, *Multiple-Input Describing
Functions and Nonlinear System Design*, McGraw-Hill, 1968) and of python-control's
:mod:`control.descfcn`: saturation, dead zone, relay with hysteresis and the play
(friction-dominated backlash).  Convention, that of the rest of the toolbox and of
python-control: the element's input is ``y(t) = A sin(w t)``; with ``b1``, ``a1`` the
sine and cosine Fourier coefficients of its steady-state output,

    N(A) = (b1 + j a1) / A        (output unit per input unit)

so an element with memory lags (``Im N < 0``).  None of these elements depends on the
rate, so N depends on A alone.  In python-control's Lur'e loop ``y = H u``,
``u = -F(y)`` a limit cycle solves ``H(jw) N(A) = -1``; with ``H`` in the place of this
toolbox's ``G`` (shaft torque to ``-theta_d``, ``theta_d = y``, ``T = F(y)``) that is the
toolbox's ``1 + G N = 0`` (:func:`backlash_df.limit_cycles.solve_harmonic_balance`).

:func:`nonlinearity_describing_function` maps python-control's element objects
(``saturation_nonlinearity``, ``friction_backlash_nonlinearity``,
``relay_hysteresis_nonlinearity``) to these closed forms.
"""

import functools

import numpy as np

from ._evaluation import validated

__all__ = [
    "saturation_describing_function",
    "dead_zone_describing_function",
    "relay_describing_function",
    "play_describing_function",
    "nonlinearity_describing_function",
]


def _share(excess):
    """``F(r) = 1 - (2/pi)(asin r + r sqrt(1 - r^2))`` for r in [-1, 1], from ``excess = 1 - r`` in [0, 2].

    With ``u = 2 acos r = 4 asin(sqrt(excess / 2))``, ``F = (u - sin u) / pi``, and a
    series for small u: F keeps full relative precision as r -> 1, where the printed
    form cancels.  ``F(1) = 0``, ``F(0) = 1``, ``F(-1) = 2``.
    """
    u = 4.0 * np.arcsin(np.sqrt(0.5 * np.clip(excess, 0.0, 2.0)))
    u2 = u * u
    series = u * u2 / 6.0 * (1.0 - u2 / 20.0 * (1.0 - u2 / 42.0 * (1.0 - u2 / 72.0 * (1.0 - u2 / 110.0))))
    return np.where(u < 0.1, series, u - np.sin(u)) / np.pi


def _parameter(name, value, positive=False):
    """A scalar parameter as a float: one-line ``ValueError`` unless finite and >= 0 (> 0 if ``positive``)."""
    if np.ndim(value) != 0:
        raise ValueError(f"{name} must be a number, got {value!r}")
    number = float(validated(name, value))
    if number < 0.0 or (positive and number == 0.0):
        raise ValueError(f"{name} must be {'> 0' if positive else '>= 0'}, got {number!r}")
    return number


def saturation_describing_function(amplitude, limit):
    """Describing function of the saturation ``clip(u, -limit, limit)`` of ``u = U sin(w t)``: a real gain.

    ``N_s = 1`` for ``U <= limit``, else ``(2 / pi) (asin r + r sqrt(1 - r^2))``
    with ``r = limit / U`` (Gelb and Vander Velde, 1968): the torque limit's
    describing function in a loop that also holds the backlash, and python-control's
    ``saturation_nonlinearity(limit)`` (unit slope).

    Parameters
    ----------
    amplitude : array_like
        U, the first-harmonic amplitude of the command, N m (>= 0).
    limit : float
        N m, > 0.

    Returns
    -------
    ndarray
        N_s in (0, 1], the shape of ``amplitude``.

    Examples
    --------
    >>> round(float(saturation_describing_function(2.0, 1.0)), 6)
    0.608998
    """
    amplitude = np.asarray(amplitude, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.clip(limit / amplitude, 0.0, 1.0)
        return np.where(amplitude <= limit, 1.0, 2.0 / np.pi * (np.arcsin(r) + r * np.sqrt(1.0 - r * r)))


def dead_zone_describing_function(amplitude, half_width, *, slope=1.0):
    """Describing function of the dead zone ``slope (y - d sign y)`` for ``|y| > d``, 0 inside: a real gain.

    ``N = slope F(d / A)`` for ``A > d``, 0 for ``A <= d``, with Tustin's
    ``F(r) = 1 - (2/pi)(asin r + r sqrt(1 - r^2))`` (Gelb and Vander Velde, 1968),
    evaluated so that it keeps full relative precision as ``A -> d``.  It is the
    toolbox's ``dead-zone`` law (24) with ``k = slope``, ``alpha = d``.

    Parameters
    ----------
    amplitude : array_like
        A, the input's amplitude (> 0), in the input's unit.
    half_width : float
        d, half the width of the dead zone (>= 0), in the input's unit.
    slope : float
        Gain outside the dead zone (> 0), output unit per input unit.

    Returns
    -------
    ndarray
        N, output unit per input unit, the shape of ``amplitude``.

    Raises
    ------
    ValueError
        Amplitude not > 0, half width negative, slope not > 0, anything non-finite.

    Examples
    --------
    >>> round(float(dead_zone_describing_function(2.0, 1.0)), 6)
    0.391002
    """
    amplitude = validated("amplitude", amplitude, positive=True)
    half_width = _parameter("half_width", half_width)
    slope = _parameter("slope", slope, positive=True)
    return slope * _share((amplitude - half_width) / amplitude)


def relay_describing_function(amplitude, level, *, hysteresis=0.0):
    """Describing function of the relay with hysteresis: output ``+-level``, switching at ``+-hysteresis``.

    python-control's ``relay_hysteresis_nonlinearity(b, c)`` with ``b = level`` and
    ``c = hysteresis`` (FBS2e, Example 10.12): the output is ``b`` once the input has
    exceeded ``c``, ``-b`` once it has fallen below ``-c``, and keeps its branch in between
    (the loop is ``2 c`` wide).  For ``A > c`` (Gelb and Vander Velde, 1968):

        ``N = (4 b / (pi A)) (sqrt(1 - (c / A)^2) - j c / A)``,

    the ideal relay's ``4 b / (pi A)`` at ``c = 0``.  For ``A <= c`` the relay never
    switches: its output is constant, without first harmonic, and N = 0
    (python-control's closed form returns NaN below ``c``).

    Parameters
    ----------
    amplitude : array_like
        A, the input's amplitude (> 0), in the input's unit.
    level : float
        b, the output's magnitude (> 0), in the output's unit.
    hysteresis : float
        c, the switching threshold (>= 0), in the input's unit.

    Returns
    -------
    complex ndarray
        N, output unit per input unit, the shape of ``amplitude``; ``Im N <= 0`` (a lag).

    Raises
    ------
    ValueError
        Amplitude not > 0, level not > 0, hysteresis negative, anything non-finite.

    Examples
    --------
    >>> n = relay_describing_function(2.0, 1.0, hysteresis=1.0)
    >>> round(float(n.real), 6), round(float(n.imag), 6)
    (0.551329, -0.31831)
    """
    amplitude = validated("amplitude", amplitude, positive=True)
    level = _parameter("level", level, positive=True)
    c = _parameter("hysteresis", hysteresis)
    switching = amplitude > c
    a = np.where(switching, amplitude, 1.0)  # no square root of a negative number where A <= c
    n = 4.0 * level / (np.pi * a * a) * (np.sqrt((a - c) * (a + c)) - 1j * c)
    return np.where(switching, n, 0.0 + 0.0j)


def play_describing_function(amplitude, width):
    """Describing function of the play (backlash hysteresis) of total width ``b``: complex, a lag.

    python-control's ``friction_backlash_nonlinearity(b)`` (Gelb and Vander Velde,
    1968, no. 48): the output stays put while the input moves within ``b / 2`` of it and
    follows the input at ``b / 2`` behind once pushed.  With ``r = b / A``, for ``A > b / 2``:

        ``Re N = (1 + f(1 - r)) / 2``,  ``Im N = -r (2 - r) / pi``,

    ``f(x) = (2/pi)(asin x + x sqrt(1 - x^2))``; ``N = 0`` for ``A <= b / 2`` (the
    output never moves) and ``N = 1`` for ``b = 0``.  The real part is evaluated so
    that it keeps full relative precision as ``A -> b / 2``.

    Parameters
    ----------
    amplitude : array_like
        A, the input's amplitude (> 0), in the input's unit.
    width : float
        b, the total play (>= 0), in the input's unit.

    Returns
    -------
    complex ndarray
        N (dimensionless), the shape of ``amplitude``.

    Raises
    ------
    ValueError
        Amplitude not > 0, width negative, anything non-finite.

    Examples
    --------
    >>> n = play_describing_function(1.0, 1.0)
    >>> round(float(n.real), 6), round(float(n.imag), 6)
    (0.5, -0.31831)
    """
    amplitude = validated("amplitude", amplitude, positive=True)
    b = _parameter("width", width)
    excess = (2.0 * amplitude - b) / amplitude  # 2 - r, exact to one rounding
    real = 0.5 * _share(excess)  # (1 + f(1 - r)) / 2 = F(r - 1) / 2, F(t) = 1 - f(t)
    imag = -(b / amplitude) * excess / np.pi
    return np.where(excess > 0.0, real + 1j * imag, 0.0 + 0.0j)


def nonlinearity_describing_function(nonlinearity):
    """The closed-form describing function ``N(A)`` of a python-control nonlinearity object.

    Reads the element's parameters from its attributes:

    * ``control.saturation_nonlinearity(ub)`` (symmetric, ``lb = -ub``):
      :func:`saturation_describing_function` with ``limit = ub``;
    * ``control.friction_backlash_nonlinearity(b)``: :func:`play_describing_function`
      with ``width = b``;
    * ``control.relay_hysteresis_nonlinearity(b, c)``: :func:`relay_describing_function`
      with ``level = b``, ``hysteresis = c``.

    Parameters
    ----------
    nonlinearity : object
        One of python-control's three element objects above.

    Returns
    -------
    functools.partial
        ``amplitude -> N``, vectorised over the amplitude (the amplitude of the
        element's input ``y``); as ``n_of`` of
        :func:`~backlash_df.limit_cycles.solve_harmonic_balance`:
        ``lambda A, w: N(A) + 0 * w``.

    Raises
    ------
    ValueError
        Any other object (named by its type); an asymmetric saturation (its
        describing function about zero bias misses the DC term); parameters the
        closed form refuses.

    Examples
    --------
    >>> import control as ct
    >>> N = nonlinearity_describing_function(ct.friction_backlash_nonlinearity(1.0))
    >>> n = N([0.4, 1.0])
    >>> complex(n[0]), round(float(n[1].real), 6)
    (0j, 0.5)
    """
    import control

    if isinstance(nonlinearity, control.saturation_nonlinearity):
        if nonlinearity.lb != -nonlinearity.ub:
            raise ValueError(f"an asymmetric saturation (lb = {nonlinearity.lb!r}, ub = {nonlinearity.ub!r}) "
                             "has no describing function about zero bias here")
        return functools.partial(saturation_describing_function, limit=_parameter("ub", nonlinearity.ub, True))
    if isinstance(nonlinearity, control.friction_backlash_nonlinearity):
        return functools.partial(play_describing_function, width=_parameter("b", nonlinearity.b))
    if isinstance(nonlinearity, control.relay_hysteresis_nonlinearity):
        return functools.partial(relay_describing_function, level=_parameter("b", nonlinearity.b, True),
                                 hysteresis=_parameter("c", nonlinearity.c))
    raise ValueError(f"no closed-form describing function for a {type(nonlinearity).__qualname__} object "
                     "(python-control's saturation_nonlinearity, friction_backlash_nonlinearity and "
                     "relay_hysteresis_nonlinearity have one)")
