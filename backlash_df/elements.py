"""The classical nonlinear elements of a Lur'e loop, as piecewise-affine hybrid automata.

python-control's describing-function elements and the textbooks' (Gelb and Vander Velde,
*Multiple-Input Describing Functions and Nonlinear System Design*, 1968):

* :class:`Saturation` ``clip(y, -L, L)`` (``control.saturation_nonlinearity(L)``);
* :class:`DeadZone` ``s (y - d sign y)`` outside ``|y| <= d``, 0 inside;
* :class:`Relay` with hysteresis: ``+M`` once ``y`` has exceeded ``h``, ``-M`` once it
  has fallen below ``-h`` (``control.relay_hysteresis_nonlinearity(M, h)``);
* :class:`Play` of total width ``b``: the output stays put while the input moves within
  ``b / 2`` of it and follows at ``b / 2`` behind once pushed
  (``control.friction_backlash_nonlinearity(b)``, friction-dominated backlash);
* :class:`ShaftLaw`: the toolbox's piecewise-affine backlash laws of an elastic shaft,
  ``dead-zone`` (24), ``damped-dead-zone`` (26) and ``revised-dead-zone`` (27), with ``y``
  as theta_d (:func:`element_of` maps a :func:`~backlash_df.make_model` law to one).

Each is exact as a hybrid automaton whose every mode is affine in the element's input
``y``, its rate ``dy/dt`` and, for the play, its memory ``m`` (the held output)::

    F = a_y y + a_m m + a_0 + a_dy dy/dt,      dm/dt = rate * dy/dt,

and whose switches are the zero crossings, in a given direction, of affine guards
``g = g_y y + g_dy dy/dt + g_m m + g_0``.  :mod:`backlash_df.lure` closes a linear
system around one of them and integrates, shoots and predicts on these modes; their
describing functions are the closed forms of :mod:`backlash_df.describing.classical`.
:func:`element_of` maps python-control's element objects to them.
"""

import dataclasses
import functools
import math

from .describing import describing_function
from .describing.classical import (
    dead_zone_describing_function,
    play_describing_function,
    relay_describing_function,
    saturation_describing_function,
)
from .models import StaticModel, make_model

__all__ = ["Saturation", "DeadZone", "Relay", "Play", "ShaftLaw", "Mode", "Guard", "element_of"]


@dataclasses.dataclass(frozen=True)
class Mode:
    """One smooth piece: ``F = a_y y + a_m m + a_0 + a_dy dy/dt``, ``dm/dt = rate dy/dt``, left by its guards."""

    name: str
    output: tuple  # (a_y, a_m, a_0)
    guards: tuple  # of Guard
    rate: float = 0.0
    output_rate: float = 0.0  # a_dy: a damper's c


@dataclasses.dataclass(frozen=True)
class Guard:
    """A switch: ``g = g_y y + g_dy dy/dt + g_m m + g_0`` crosses zero upward (``direction`` +1) or downward (-1)."""

    coefficients: tuple  # (g_y, g_dy, g_m, g_0)
    direction: int
    target: int


def _positive(name, value):
    """``value`` as a float; one-line ``ValueError`` unless finite and > 0."""
    number = float(value)
    if not (number > 0.0 and math.isfinite(number)):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return number


def _sided_modes(level, inside, above, below):
    """The three modes of a two-sided threshold ``|y| = level``, each ``(name, output)``: inside, left
    across ``+level`` upward to above and ``-level`` downward to below; above and below, back across it."""
    return (Mode(*inside, (Guard((1.0, 0.0, 0.0, -level), 1, 1), Guard((1.0, 0.0, 0.0, level), -1, 2))),
            Mode(*above, (Guard((1.0, 0.0, 0.0, -level), -1, 0),)),
            Mode(*below, (Guard((1.0, 0.0, 0.0, level), 1, 0),)))


class _Element:
    """What every element shares: the label, the DF's threshold, the mode found from a state."""

    memory = False  # whether the element carries a continuous state m

    @property
    def label(self):
        """The element and its values, for results: ``"play (b = 1)"``."""
        values = ", ".join(f"{symbol} = {value:.6g}" for symbol, value in self.symbols())
        return f"{self.kind} ({values})"

    def mode_at(self, y, dy, m=0.0, branch=1):
        """The mode the element is in at input ``y``, rate ``dy``, memory ``m`` (a relay's ``branch`` where undecided).

        The mode whose guards do not fire at once: for each candidate, the state must lie on
        the mode's side of every guard (strictly, or on it and moving away).
        """
        for index in self.candidates(branch):
            if all(not _fires(guard, y, dy, m, self.modes[index]) for guard in self.modes[index].guards):
                return index
        raise ValueError(f"no mode of the {self.label} holds y = {y!r}, dy/dt = {dy!r}, m = {m!r}")

    def candidates(self, branch):
        """The modes in the order :meth:`mode_at` tries them."""
        return range(len(self.modes))

    def output(self, mode, y, m=0.0):
        """F (the element's output) in ``mode``."""
        a_y, a_m, a_0 = self.modes[mode].output
        return a_y * y + a_m * m + a_0


def _fires(guard, y, dy, m, mode):
    """Whether ``guard`` of ``mode`` is already crossed at (y, dy, m): beyond it in its direction."""
    g_y, g_dy, g_m, g_0 = guard.coefficients
    value = g_y * y + g_dy * dy + g_m * m + g_0
    return guard.direction * value > 0.0 or (value == 0.0 and guard.direction * g_y * dy > 0.0)


@dataclasses.dataclass(frozen=True)
class Saturation(_Element):
    """``clip(y, -limit, limit)``: modes linear, upper, lower."""

    limit: float
    kind = "saturation"

    def __post_init__(self):
        object.__setattr__(self, "limit", _positive("the saturation's limit", self.limit))

    def symbols(self):
        """``((symbol, value), ...)``: the element's values, for its label."""
        return (("L", self.limit),)

    @functools.cached_property
    def modes(self):
        """The element's :class:`Mode` s, indexed as the guards' targets."""
        lim = self.limit
        return _sided_modes(lim, ("linear", (1.0, 0.0, 0.0)), ("upper", (0.0, 0.0, lim)), ("lower", (0.0, 0.0, -lim)))

    @property
    def threshold(self):
        """0: a saturation passes every amplitude (N = 1 up to its limit)."""
        return 0.0

    def describing_function(self, amplitude, omega=None):
        """N(A) = :func:`~backlash_df.describing.classical.saturation_describing_function` (``omega`` unused)."""
        return saturation_describing_function(amplitude, self.limit) + 0j


@dataclasses.dataclass(frozen=True)
class DeadZone(_Element):
    """``slope (y - half_width sign y)`` for ``|y| > half_width``, 0 inside."""

    half_width: float
    slope: float = 1.0
    kind = "dead zone"

    def __post_init__(self):
        object.__setattr__(self, "half_width", _positive("the dead zone's half width", self.half_width))
        object.__setattr__(self, "slope", _positive("the dead zone's slope", self.slope))

    def symbols(self):
        """``((symbol, value), ...)``: the element's values, for its label."""
        return (("d", self.half_width), ("s", self.slope))

    @functools.cached_property
    def modes(self):
        """The element's :class:`Mode` s, indexed as the guards' targets."""
        d, s = self.half_width, self.slope
        return _sided_modes(d, ("inside", (0.0, 0.0, 0.0)), ("above", (s, 0.0, -s * d)), ("below", (s, 0.0, s * d)))

    @property
    def threshold(self):
        """Amplitudes at or below which N is zero (the DF's search starts above it)."""
        return self.half_width

    def describing_function(self, amplitude, omega=None):
        """N(A) = :func:`~backlash_df.describing.classical.dead_zone_describing_function` (``omega`` unused)."""
        return dead_zone_describing_function(amplitude, self.half_width, slope=self.slope) + 0j


@dataclasses.dataclass(frozen=True)
class Relay(_Element):
    """``+level`` once y has exceeded ``hysteresis``, ``-level`` once below ``-hysteresis``; modes high, low."""

    level: float
    hysteresis: float = 0.0
    kind = "relay"

    def __post_init__(self):
        object.__setattr__(self, "level", _positive("the relay's level", self.level))
        hysteresis = float(self.hysteresis)
        if not (hysteresis >= 0.0 and math.isfinite(hysteresis)):
            raise ValueError(f"the relay's hysteresis must be finite and >= 0, got {self.hysteresis!r}")
        object.__setattr__(self, "hysteresis", hysteresis)

    def symbols(self):
        """``((symbol, value), ...)``: the element's values, for its label."""
        return (("M", self.level), ("h", self.hysteresis))

    @functools.cached_property
    def modes(self):
        """The element's :class:`Mode` s, indexed as the guards' targets."""
        h, level = self.hysteresis, self.level
        return (Mode("high", (0.0, 0.0, level), (Guard((1.0, 0.0, 0.0, h), -1, 1),)),
                Mode("low", (0.0, 0.0, -level), (Guard((1.0, 0.0, 0.0, -h), 1, 0),)))

    def candidates(self, branch):
        """Between the thresholds both modes hold: ``branch`` (+1 high, -1 low) decides."""
        return (0, 1) if branch > 0 else (1, 0)

    @property
    def threshold(self):
        """Amplitudes at or below which N is zero (the DF's search starts above it)."""
        return self.hysteresis

    def describing_function(self, amplitude, omega=None):
        """N(A) = :func:`~backlash_df.describing.classical.relay_describing_function` (``omega`` unused)."""
        return relay_describing_function(amplitude, self.level, hysteresis=self.hysteresis)


@dataclasses.dataclass(frozen=True)
class Play(_Element):
    """The play of total width ``width``: modes held (``F = m``), pushed up (``F = y - b/2``), pushed down."""

    width: float
    kind = "play"
    memory = True

    def __post_init__(self):
        object.__setattr__(self, "width", _positive("the play's width", self.width))

    def symbols(self):
        """``((symbol, value), ...)``: the element's values, for its label."""
        return (("b", self.width),)

    @functools.cached_property
    def modes(self):
        """The element's :class:`Mode` s, indexed as the guards' targets."""
        half = 0.5 * self.width
        return (Mode("held", (0.0, 1.0, 0.0), (Guard((1.0, 0.0, -1.0, -half), 1, 1),
                                               Guard((1.0, 0.0, -1.0, half), -1, 2))),
                Mode("pushed up", (1.0, 0.0, -half), (Guard((0.0, 1.0, 0.0, 0.0), -1, 0),), rate=1.0),
                Mode("pushed down", (1.0, 0.0, half), (Guard((0.0, 1.0, 0.0, 0.0), 1, 0),), rate=1.0))

    @property
    def threshold(self):
        """Amplitudes at or below which N is zero (the DF's search starts above it)."""
        return 0.5 * self.width

    def describing_function(self, amplitude, omega=None):
        """N(A) = :func:`~backlash_df.describing.classical.play_describing_function` (``omega`` unused)."""
        return play_describing_function(amplitude, self.width)


#: The toolbox's laws that are piecewise affine, as :class:`ShaftLaw` takes them.
SHAFT_LAWS = ("dead-zone", "damped-dead-zone", "revised-dead-zone")


@dataclasses.dataclass(frozen=True)
class ShaftLaw(_Element):
    """A piecewise-affine backlash law of :mod:`backlash_df.models` with ``y`` as theta_d: modes free, right
    and left contact, ``F = k (y -+ alpha) + c dy/dt`` in contact (``c`` unused by the dead-zone (24)).

    ``dead-zone`` and ``damped-dead-zone`` (26) are in contact while ``|y| > alpha``;
    ``revised-dead-zone`` (27) while ``k |y| + c sign(y) dy/dt > k alpha`` (it releases where the
    torque would pull).  A damper's torque depends on ``dy/dt``: H needs a relative degree of at
    least 2 (:func:`~backlash_df.lure.lure_loop` says so in one line).
    """

    law: str
    stiffness: float
    half_gap: float
    damping: float = 0.0
    kind = "shaft law"

    def __post_init__(self):
        if self.law not in SHAFT_LAWS:
            raise ValueError(f"a Lur'e loop takes the piecewise-affine laws {', '.join(SHAFT_LAWS)}, not "
                             f"{self.law!r} (its contact is not affine in theta_d and its rate)")
        object.__setattr__(self, "stiffness", _positive("the shaft's stiffness", self.stiffness))
        object.__setattr__(self, "half_gap", _positive("the shaft's half gap", self.half_gap))
        damping = float(self.damping)
        if not (damping >= 0.0 and math.isfinite(damping)):
            raise ValueError(f"the shaft's damping must be finite and >= 0, got {self.damping!r}")
        object.__setattr__(self, "damping", 0.0 if self.law == "dead-zone" else damping)

    @property
    def label(self):
        """The law and its shaft: ``"damped-dead-zone (k = 1, c = 0.2, alpha = 0.5)"``."""
        values = f"k = {self.stiffness:.6g}, c = {self.damping:.6g}, alpha = {self.half_gap:.6g}"
        return f"{self.law} ({values})"

    @functools.cached_property
    def modes(self):
        """Free, right contact, left contact."""
        k, c, alpha = self.stiffness, self.damping, self.half_gap
        # the contact's guard: y = +-alpha, or (revised) k y + c dy = +-k alpha
        g_dy = c / k if self.law == "revised-dead-zone" else 0.0
        return (Mode("free", (0.0, 0.0, 0.0), (Guard((1.0, g_dy, 0.0, -alpha), 1, 1),
                                               Guard((1.0, g_dy, 0.0, alpha), -1, 2))),
                Mode("right contact", (k, 0.0, -k * alpha), (Guard((1.0, g_dy, 0.0, -alpha), -1, 0),), output_rate=c),
                Mode("left contact", (k, 0.0, k * alpha), (Guard((1.0, g_dy, 0.0, alpha), 1, 0),), output_rate=c))

    @property
    def threshold(self):
        """alpha: below it the shaft never touches (N = 0)."""
        return self.half_gap

    def model(self):
        """The law as :func:`~backlash_df.make_model` builds it."""
        return make_model(self.law, stiffness=self.stiffness, damping=self.damping, half_gap=self.half_gap)

    def describing_function(self, amplitude, omega=None):
        """N(A, w) = :func:`~backlash_df.describing_function` of the law (N m/rad; rate-dependent with a damper)."""
        return describing_function(self.model(), amplitude, 0.0 if omega is None else omega)


def element_of(nonlinearity):
    """The element a python-control nonlinearity object stands for, or one of this module's, unchanged.

    ``control.saturation_nonlinearity(ub)`` (symmetric) is :class:`Saturation` ``(ub)``,
    ``control.friction_backlash_nonlinearity(b)`` is :class:`Play` ``(b)``,
    ``control.relay_hysteresis_nonlinearity(b, c)`` is :class:`Relay` ``(b, c)``; a
    ``dead-zone``, ``damped-dead-zone`` or ``revised-dead-zone`` law of
    :func:`~backlash_df.make_model` is a :class:`ShaftLaw` with its shaft.

    Raises
    ------
    ValueError
        Any other object, named by its type; an asymmetric saturation; values the element refuses.

    Examples
    --------
    >>> import control as ct
    >>> element_of(ct.friction_backlash_nonlinearity(1.0)).label
    'play (b = 1)'
    """
    if isinstance(nonlinearity, (Saturation, DeadZone, Relay, Play, ShaftLaw)):
        return nonlinearity
    if isinstance(nonlinearity, StaticModel):
        k, c, alpha, _ = nonlinearity.params
        return ShaftLaw(nonlinearity.name, k, alpha, c)
    import control

    if isinstance(nonlinearity, control.saturation_nonlinearity):
        if nonlinearity.lb != -nonlinearity.ub:
            raise ValueError(f"an asymmetric saturation (lb = {nonlinearity.lb!r}, ub = {nonlinearity.ub!r}) "
                             "has no describing function about zero bias here")
        return Saturation(nonlinearity.ub)
    if isinstance(nonlinearity, control.friction_backlash_nonlinearity):
        return Play(nonlinearity.b)
    if isinstance(nonlinearity, control.relay_hysteresis_nonlinearity):
        return Relay(nonlinearity.b, nonlinearity.c)
    raise ValueError(f"no element for a {type(nonlinearity).__qualname__} object: a Lur'e loop takes "
                     "backlash_df.elements' Saturation, DeadZone, Relay, Play and ShaftLaw, a piecewise-affine law "
                     "of make_model, or python-control's saturation_nonlinearity, friction_backlash_nonlinearity "
                     "and relay_hysteresis_nonlinearity")
