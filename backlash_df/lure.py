"""A user's Lur'e loop: a python-control LTI ``H`` closed by one classical element ``F``, analysed exactly.

python-control's convention (:mod:`control.descfcn`)::

    y = H u,    u = -F(y),

``H`` SISO, continuous time and strictly proper (``D = 0``: a memoryless ``F`` on a
proper ``H`` would close an algebraic loop), realised as ``dx/dt = A x + B u``,
``y = C x``; ``F`` one of :mod:`backlash_df.elements` (saturation, dead zone, relay,
play) or python-control's element object for it.  A limit cycle of the describing
function solves ``H(jw) N(A) = -1``, ``A`` the first-harmonic amplitude of ``y``: the
toolbox's harmonic balance ``1 + G N = 0`` with ``G = H``.

Every mode of the element is affine, so the closed loop is piecewise affine in the
augmented state ``X = [x, m]`` (``m`` the play's held output, absent for the other
elements): ``dX/dt = M_k X + q_k`` in mode ``k``.  Here

* :meth:`LureLoop.predict` solves the harmonic balance with the element's closed-form
  DF (:func:`~backlash_df.limit_cycles.solve_harmonic_balance`: Loeb stability, near
  misses);
* :meth:`LureLoop.simulate` integrates the loop exactly: each mode's flow is the matrix
  exponential of ``[[M_k, q_k], [0, 0]]``, each switch the root of its affine guard along
  that flow (Brent's method to round-off);
* :meth:`LureLoop.periodic_orbit` shoots for a periodic orbit (Newton on
  ``X(T) - X(0) = 0``, ``y(0) = l``): the monodromy matrix is the product of the modes'
  exponentials and the switches' saltation matrices
  ``S = I + (f+ - f-) n^T / (n . f-)`` (Aizerman and Gantmacher; Leine and Nijmeijer,
  2004), so Newton converges quadratically, unstable orbits included, and the
  Floquet multipliers are its eigenvalues less the trivial one.
"""

import dataclasses
import functools
import math

import numpy as np
import scipy.linalg
import scipy.optimize

from ._json import json_ready
from ._threads import single_threaded_blas
from .elements import element_of
from .loops import frequency_response_of
from .limit_cycles import LimitCyclePrediction, solve_harmonic_balance
from .orbits import OrbitNotFound
from .plotting import ResultPlot, axes_or_new

__all__ = ["LureLoop", "LureOrbit", "LureSimulation", "lure_loop"]

#: Steps per period (or per fastest time constant) at which the guards are sampled for crossings.
_STEPS_PER_PERIOD = 256
#: A state beyond this has overflowed for any purpose of the analysis (the loop runs away).
_OVERFLOW = 1e100
#: Switches within one call of the flow beyond which the element chatters (a sliding mode).
_MAX_SWITCHES = 10000
#: Gauss-Legendre nodes per piece of a segment in the orbit's first-harmonic integrals.
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(12)


def lure_loop(system, nonlinearity):
    """The Lur'e loop ``y = H u``, ``u = -F(y)`` of a python-control LTI and one element.

    Parameters
    ----------
    system : control.LTI
        ``H``: SISO, continuous time, strictly proper (a transfer function or state space).
    nonlinearity : element
        :class:`~backlash_df.elements.Saturation`, :class:`~backlash_df.elements.DeadZone`,
        :class:`~backlash_df.elements.Relay`, :class:`~backlash_df.elements.Play`, or
        python-control's ``saturation_nonlinearity``, ``relay_hysteresis_nonlinearity``,
        ``friction_backlash_nonlinearity``.

    Returns
    -------
    LureLoop

    Raises
    ------
    ValueError
        One line: a MIMO, discrete-time, improper or proper-but-not-strictly-proper ``H``;
        an object that is not an element.

    Examples
    --------
    python-control's backlash example: two describing-function cycles, both unstable.

    >>> import control as ct
    >>> H = ct.tf(4, [1, 2, 2, 1]) * ct.tf(*ct.pade(5, 4))
    >>> loop = lure_loop(H, ct.friction_backlash_nonlinearity(1))
    >>> [(round(c.amplitude, 3), round(c.omega, 4), c.stable) for c in loop.predict().cycles]
    [(0.626, 0.3103, False), (0.874, 1.2156, False)]
    """
    import control as ct

    if not isinstance(system, ct.LTI) or isinstance(system, ct.FrequencyResponseData):
        raise ValueError(f"H must be a python-control transfer function or state space, got a "
                         f"{type(system).__qualname__}")
    if system.ninputs != 1 or system.noutputs != 1:
        raise ValueError(f"H must be SISO, got {system.ninputs} inputs and {system.noutputs} outputs")
    if not system.isctime(strict=True):
        raise ValueError("H must be continuous time (a discrete-time H is not analysed here)")
    if isinstance(system, ct.TransferFunction):
        num, den = (np.trim_zeros(np.atleast_1d(np.squeeze(p)), "f") for p in (system.num[0][0], system.den[0][0]))
        if num.size > den.size:
            raise ValueError(f"H must be proper: its numerator has degree {num.size - 1} above the "
                             f"denominator's {den.size - 1}")
    realised = ct.ss(system)
    a, b, c, d = (np.asarray(m, dtype=float) for m in (realised.A, realised.B, realised.C, realised.D))
    if d[0, 0] != 0.0:
        raise ValueError(f"H must be strictly proper (D = {d[0, 0]:.6g}): a feedthrough closes an algebraic loop "
                         "through the element")
    if a.shape[0] == 0:
        raise ValueError("H has no state: a static gain closes an algebraic loop through the element")
    element = element_of(nonlinearity)
    scale = max(float(np.abs(c).max() * np.abs(b).max()), 1e-300)
    first_degree = abs(float(c[0] @ b[:, 0])) > 1e-12 * scale
    if any(m.output_rate for m in element.modes) and first_degree:
        raise ValueError(f"the {element.label} depends on dy/dt: H needs a relative degree of at least 2 (its "
                         "dy/dt a function of its state), this one has 1")
    if getattr(element, "hysteresis", None) == 0.0 and first_degree:
        raise ValueError(f"an ideal {element.label} on H of relative degree 1 slides on y = 0 (a Filippov sliding "
                         "mode, not modelled here): give the relay a hysteresis or H a relative degree of 2")
    return LureLoop(system=system, element=element, a=a, b=b[:, 0], c=c[0])


@dataclasses.dataclass(frozen=True, eq=False)
class LureLoop:
    """``y = H u``, ``u = -F(y)``: the realisation ``(A, B, C)`` of H and the element F (module docs).

    Build with :func:`lure_loop`.
    """

    system: object
    element: object
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray

    @property
    def label(self):
        """The element, for results: ``"play (b = 1)"``."""
        return self.element.label

    @property
    def size(self):
        """Dimension of the augmented state ``X = [x, m]``."""
        return self.a.shape[0] + int(self.element.memory)

    def __repr__(self):
        return f"<LureLoop: H of order {self.a.shape[0]} closed by {self.label}>"

    # ------------------------------------------------------------------ the modes

    def with_value(self, parameter, value):
        """This loop with ``parameter`` at ``value``: ``"gain"`` scales H (its output row ``C``, the states
        unchanged), any other name is a value of the element (``limit``, ``width``, ``hysteresis``, ...).

        Raises
        ------
        ValueError
            An unknown parameter, or a value the element refuses: one line.
        """
        if parameter == "gain":
            gain = float(value)
            if not (gain > 0.0 and math.isfinite(gain)):
                raise ValueError(f"the gain must be finite and > 0, got {value!r}")
            return LureLoop(system=self.system * gain, element=self.element, a=self.a, b=self.b, c=self.c * gain)
        fields = [f.name for f in dataclasses.fields(self.element)]
        if parameter not in fields:
            raise ValueError(f"unknown parameter {parameter!r} of a {self.element.kind} loop: 'gain' or one of "
                             f"{', '.join(fields)}")
        element = dataclasses.replace(self.element, **{parameter: float(value)})
        return LureLoop(system=self.system, element=element, a=self.a, b=self.b, c=self.c)

    def mode_system(self, mode):
        """``(M, q, y_row, dy_row, dy_0, f_row, f_0)`` of ``mode``: ``dX/dt = M X + q``, ``y = y_row . X``,
        ``dy/dt = dy_row . X + dy_0``, ``F = f_row . X + f_0``."""
        return self._mode_systems[mode]

    @functools.cached_property
    def _mode_systems(self):
        return tuple(_mode_system(self, k) for k in range(len(self.element.modes)))

    def state_of(self, x, m=0.0):
        """The augmented state ``X`` from H's state ``x`` and the play's output ``m`` (ignored for other elements)."""
        x = np.asarray(x, dtype=float)
        return np.append(x, m) if self.element.memory else x.copy()

    def signals(self, mode, state):
        """``(y, dy/dt, m, F)`` at augmented state(s) ``state`` (last axis) in ``mode``."""
        _, _, y_row, dy_row, dy_0, f_row, f_0 = self.mode_system(mode)
        state = np.asarray(state, dtype=float)
        m = state[..., -1] if self.element.memory else np.zeros(state.shape[:-1])
        return state @ y_row, state @ dy_row + dy_0, m, state @ f_row + f_0

    # ------------------------------------------------------------------ the analyses

    def predict(self, *, amplitude_range=None, omega_range=None, grid=(60, 80), near_miss_cutoff=0.5):
        """The describing function's limit cycles: all roots of ``1 + H(jw) N(A) = 0`` in a box.

        Parameters
        ----------
        amplitude_range : (float, float), optional
            A (the first-harmonic amplitude of y, y's unit); default from the element's
            threshold up to 1000 times its scale.
        omega_range : (float, float), optional
            rad/s; default a decade beyond H's slowest and fastest pole or zero.
        grid, near_miss_cutoff
            As :func:`~backlash_df.limit_cycles.solve_harmonic_balance`.

        Returns
        -------
        LimitCyclePrediction
            ``model`` the element's label, ``linear`` and ``user_linear`` H, ``law`` None.
        """
        omega_range = _omega_range(self.system) if omega_range is None else tuple(omega_range)
        amplitude_range = (_amplitude_range(self, omega_range) if amplitude_range is None
                           else tuple(amplitude_range))

        def n_of(amplitude, omega):
            return self.element.describing_function(amplitude, omega) + 0.0 * omega

        threshold = self.element.threshold
        cycles, near = solve_harmonic_balance(functools.partial(frequency_response_of, self.system), n_of, threshold, amplitude_range, omega_range, grid=grid,
                                              near_miss_cutoff=near_miss_cutoff)
        return LimitCyclePrediction(
            model=self.label, cycles=tuple(cycles), near_misses=tuple(near), amplitude_range=amplitude_range,
            omega_range=omega_range, linear=self.system, describing=n_of, half_gap=threshold,
            user_linear=self.system, amplitude_unit="", linear_name="H", linear_unit="",
        )

    def simulate(self, t_end, *, x0=None, y0=None, m0=None, branch=1, dt=None):
        """The closed loop integrated exactly from a state (module docs).

        Parameters
        ----------
        t_end : float
            s, > 0.
        x0 : array_like, optional
            H's initial state (default: the state of least norm with ``y = y0``).
        y0 : float, optional
            Initial output when ``x0`` is not given (default 1.5 times the element's
            threshold, or 1).
        m0 : float, optional
            The play's initial output, clipped into ``[y - b/2, y + b/2]`` (default 0).
        branch : int
            The relay's branch where the input starts between its thresholds (+1 high, -1 low).
        dt : float, optional
            Output step, s (default ``t_end / 4000``).

        Returns
        -------
        LureSimulation
        """
        if not (t_end > 0.0 and math.isfinite(t_end)):
            raise ValueError(f"t_end must be finite and > 0, got {t_end!r}")
        dt = t_end / 4000 if dt is None else float(dt)
        if not (0.0 < dt <= t_end):
            raise ValueError(f"dt must be in (0, t_end], got {dt!r}")
        state, mode = self.start(x0, y0, m0, branch)
        with single_threaded_blas():
            return self.run(state, mode, t_end, dt)

    def run(self, state, mode, t_end, dt, bound=_OVERFLOW):
        """:meth:`simulate` from an augmented ``state`` in the element's ``mode`` (as :meth:`start` gives them).

        A run whose ``|y|`` passes ``bound`` (or whose state passes 1e100) stops there, ``diverged``.
        """
        flow = _Flow(self)
        times = np.arange(int(round(t_end / dt)) + 1) * dt
        states, modes = np.empty((times.size, self.size)), np.empty(times.size, dtype=int)
        states[0], modes[0] = state, mode
        diverged, events = False, []
        for i in range(1, times.size):
            try:
                mode, state, _ = flow.advance(mode, state, dt, events)
            except _Overflow:
                diverged = True
            diverged = diverged or abs(self.c @ state[: self.c.size]) > bound
            if diverged:
                times, states, modes = times[:i], states[:i], modes[:i]
                break
            states[i], modes[i] = state, mode
        y, output = np.empty(times.size), np.empty(times.size)
        for k in np.unique(modes):
            at = modes == k
            y[at], _, _, output[at] = self.signals(int(k), states[at])
        return LureSimulation(self.label, times, y, output, states, modes, diverged, len(events))

    def start(self, x0=None, y0=None, m0=None, branch=1):
        """``(state, mode)``: the augmented initial state and the element's mode there (arguments of :meth:`simulate`)."""
        n = self.a.shape[0]
        if x0 is None:
            y_start = (1.5 * self.element.threshold or 1.0) if y0 is None else float(y0)
            x = self.c * (y_start / float(self.c @ self.c))
        else:
            x = np.asarray(x0, dtype=float).reshape(-1)
            if x.shape != (n,) or not np.all(np.isfinite(x)):
                raise ValueError(f"x0 must hold H's {n} states, finite, got {x0!r}")
        y = float(self.c @ x)
        m = 0.0 if m0 is None else float(m0)
        if self.element.memory:
            half = 0.5 * self.element.width
            m = min(max(m, y - half), y + half)
        free_rate = float(self.c @ (self.a @ x))  # dy/dt before the element acts (its output enters by CB)
        mode = self.element.mode_at(y, free_rate, m, branch)
        return self.state_of(x, m), mode

    def periodic_orbit(self, seed, *, tol=1e-11, max_iter=40):
        """The periodic orbit near ``seed``, by shooting with the exact monodromy (module docs).

        Parameters
        ----------
        seed : LimitCycle, LureOrbit, LureSimulation or (amplitude, omega)
            A describing-function cycle (or its A, w), an orbit already found, or a run
            that has settled onto an oscillation (from its last two upward crossings of
            its mean: the state, mode and period).
        tol : float
            Newton stops where the correction is below ``tol`` relative to the state's and
            the period's scales.
        max_iter : int

        Returns
        -------
        LureOrbit

        Raises
        ------
        OrbitNotFound
            Newton did not converge (the message says how far it got).
        """
        if isinstance(seed, LureOrbit):
            state, mode, period, level = seed.state.copy(), seed.mode, seed.period, seed.level
        elif isinstance(seed, LureSimulation):
            state, mode, period, level = _run_seed(seed)
        else:
            amplitude, omega = (seed.amplitude, seed.omega) if hasattr(seed, "omega") else map(float, seed)
            state, mode, level = _harmonic_seed(self, amplitude, omega)
            period = 2.0 * math.pi / omega
        with single_threaded_blas():
            return _shoot(self, state, mode, period, level, tol, max_iter)

    def exact_orbits(self, prediction, **options):
        """An exact orbit for every cycle of ``prediction`` (this loop's), or why shooting failed.

        Each cycle's shooting starts from its describing-function seed and, where that
        fails (a waveform far from the DF's sine), from the seeds of :data:`_SEED_LADDER`
        around it; an orbit found from another seed is the cycle's only if the cycle is
        the DF cycle nearest to it (in log A and log w).

        Returns
        -------
        tuple of (LimitCycle, LureOrbit or str)
            Each cycle with its orbit, or the :class:`~backlash_df.orbits.OrbitNotFound` message.
        """
        if prediction.user_linear is not self.system or prediction.model != self.label:
            raise ValueError(f"the prediction '{prediction.model}' is not this loop's ({self.label} around this H): "
                             "predict with loop.predict() first")
        return tuple((cycle, self._orbit_of(cycle, prediction.cycles, options)) for cycle in prediction.cycles)

    def _orbit_of(self, cycle, cycles, options):
        """The exact orbit of one DF ``cycle`` of ``cycles`` (:meth:`exact_orbits`), or the first failure's message."""
        first = None
        for amplitude_factor, omega_factor in _SEED_LADDER:
            try:
                orbit = self.periodic_orbit((cycle.amplitude * amplitude_factor, cycle.omega * omega_factor),
                                            **options)
            except OrbitNotFound as failure:
                first = first or str(failure)
                continue
            nearest = min(cycles, key=lambda c: math.hypot(math.log(c.amplitude / orbit.amplitude),
                                                          math.log(c.omega / orbit.omega)))
            if nearest is cycle:
                return orbit
        return first or f"{self.label}: shooting from the seeds around A = {cycle.amplitude:.4g} found other orbits"


#: Seeds of :meth:`LureLoop.exact_orbits` around a DF cycle: factors on its amplitude and frequency.
_SEED_LADDER = ((1.0, 1.0), (1.1, 1.0), (1.25, 1.0), (0.9, 1.0), (1.0, 1.1), (1.0, 0.9), (1.1, 1.1), (1.25, 1.1),
                (1.1, 0.9), (1.4, 1.0))


def _mode_system(loop, mode):
    """The affine field of ``mode`` over the augmented state (:meth:`LureLoop.mode_system`).

    A damper's term ``a_dy dy/dt`` enters as ``a_dy C A x``: H's relative degree is at least 2
    there (:func:`lure_loop` refuses less), so ``dy/dt`` is a state output.
    """
    spec = loop.element.modes[mode]
    a_y, a_m, a_0 = spec.output
    a, b, c = loop.a, loop.b, loop.c
    cb = float(c @ b)
    memory = loop.element.memory
    n = a.shape[0]
    size = n + int(memory)
    y_row = np.zeros(size)
    y_row[:n] = c
    f_row = a_y * y_row
    f_row[:n] += spec.output_rate * (c @ a)
    if memory:
        f_row[n] = a_m
    big_m = np.zeros((size, size))
    big_m[:n, :] = -np.outer(b, f_row)
    big_m[:n, :n] += a
    q = np.zeros(size)
    q[:n] = -b * a_0
    dy_row = c @ big_m[:n, :]
    dy_0 = -cb * a_0
    if memory:
        big_m[n, :] = spec.rate * dy_row
        q[n] = spec.rate * dy_0
    return big_m, q, y_row, dy_row, dy_0, f_row, a_0


class _Overflow(ArithmeticError):
    """The flow ran away past :data:`_OVERFLOW`; ``args[0]`` is the time elapsed in the call (s)."""


class _Chattering(ValueError):
    """The element switches without end at one place (a Filippov sliding mode); the message says so."""


class _Flow:
    """The loop's exact flow: per mode the exponentials, the guards as affine rows, event location."""

    def __init__(self, loop):
        self.loop = loop
        self.systems = loop._mode_systems
        self.guards = [[self._guard_row(k, guard) for guard in spec.guards]
                       for k, spec in enumerate(loop.element.modes)]
        fastest = max(np.abs(np.linalg.eigvals(system[0])).max() for system in self.systems)
        self.step = 0.25 / max(fastest, 1e-12)
        self._exponentials = {}

    def _guard_row(self, mode, guard):
        """``(row, constant, direction, target)``: the guard ``row . X + constant`` over the augmented state."""
        g_y, g_dy, g_m, g_0 = guard.coefficients
        _, _, y_row, dy_row, dy_0, _, _ = self.systems[mode]
        row = g_y * y_row + g_dy * dy_row
        if self.loop.element.memory:
            row = row.copy()
            row[-1] += g_m
        return row, g_0 + g_dy * dy_0, guard.direction, guard.target

    def exponential(self, mode, duration, keep=False):
        """``(Phi, psi)``: ``X(t + duration) = Phi X(t) + psi`` in ``mode`` (kept for reuse if ``keep``)."""
        key = (mode, duration)
        if key in self._exponentials:
            return self._exponentials[key]
        big_m, q = self.systems[mode][:2]
        size = q.size
        block = np.zeros((size + 1, size + 1))
        block[:size, :size], block[:size, size] = big_m, q
        flow = scipy.linalg.expm(block * duration)
        value = (flow[:size, :size], flow[:size, size])
        if keep:
            self._exponentials[key] = value
        return value

    def field(self, mode, state):
        """``dX/dt`` in ``mode``."""
        big_m, q = self.systems[mode][:2]
        return big_m @ state + q

    def advance(self, mode, state, duration, events=None, monodromy=None):
        """Flow ``duration`` from ``state`` in ``mode`` through every switch: ``(mode, state, monodromy)``.

        ``events`` (a list) collects ``(time, before, after)``; ``monodromy`` (a matrix) is
        carried along the flow, saltation included.
        """
        elapsed, switches = 0.0, 0
        while elapsed < duration:
            step = min(self.step, duration - elapsed)
            if duration - elapsed - step < 1e-12 * duration:
                step = duration - elapsed
            phi, psi = self.exponential(mode, step, keep=True)
            after = phi @ state + psi
            if not np.abs(after).max() < _OVERFLOW:
                raise _Overflow(elapsed + step)
            hit = self._first_crossing(mode, state, after, step)
            if hit is None:
                state, elapsed = after, elapsed + step
                monodromy = None if monodromy is None else phi @ monodromy
                continue
            tau, (row, _, _, target) = hit
            phi, psi = self.exponential(mode, tau) if tau != step else (phi, psi)
            state = phi @ state + psi
            if monodromy is not None:
                monodromy = self._saltation(mode, target, state, row) @ (phi @ monodromy)
            if events is not None:
                events.append((elapsed + tau, mode, target))
            mode, elapsed, switches = target, elapsed + tau, switches + 1
            if switches > _MAX_SWITCHES:
                raise _Chattering(f"the {self.loop.label} switched {switches} times in {duration:.3g} s: it chatters on "
                                  "a switching surface (a sliding mode), which the exact flow does not model")
        return mode, state, monodromy

    def _first_crossing(self, mode, before, after, step):
        """``(tau, guard)`` of the first guard crossed in its direction within ``step``, or None."""
        first = None
        for guard in self.guards[mode]:
            row, constant, direction, _ = guard
            start, end = direction * (row @ before + constant), direction * (row @ after + constant)
            if start > 0.0 or end <= 0.0:
                continue

            def value(tau, row=row, constant=constant, direction=direction):
                phi, psi = self.exponential(mode, tau) if tau != step else (None, after)
                point = after if phi is None else phi @ before + psi
                return direction * (row @ point + constant)

            tau = scipy.optimize.brentq(value, 0.0, step, xtol=1e-15 * step, rtol=1e-15, maxiter=200, disp=False)
            if value(tau) <= 0.0:  # land on the far side of the guard
                tau = min(step, tau + 4.0 * np.spacing(step))
            if first is None or tau < first[0]:
                first = (tau, guard)
        return first

    def _saltation(self, before, after, state, row):
        """``I + (f_after - f_before) n^T / (n . f_before)`` at a switch on the guard ``n . X + c = 0``."""
        f_before, f_after = self.field(before, state), self.field(after, state)
        rate = row @ f_before
        if abs(rate) < 1e-14 * (np.abs(row).sum() * np.abs(f_before).max() + 1e-300):
            raise OrbitNotFound("the orbit grazes a switching surface (its crossing speed is round-off): "
                                "the saltation matrix does not exist there")
        return np.eye(state.size) + np.outer(f_after - f_before, row) / rate


def _omega_range(system):
    """A decade beyond H's slowest and fastest pole or zero (rad/s); (0.01, 100) without any."""
    roots = np.concatenate([np.atleast_1d(system.poles()), np.atleast_1d(system.zeros())])
    scales = np.abs(roots[np.abs(roots) > 1e-9])
    return (0.01, 100.0) if scales.size == 0 else (float(scales.min()) / 10.0, float(scales.max()) * 10.0)


def _amplitude_range(loop, omega_range):
    """Where a cycle can be: just above the element's threshold (a saturation's limit) up to 10 times the
    amplitude whose first harmonic balances H's largest gain on the negative real axis in ``omega_range``
    (a saturation's ``4 L x / pi``, a relay's ``4 M x / pi``), or 1e4 times the threshold of a dead zone
    or a play, whose N tends to its slope."""
    element = loop.element
    h = frequency_response_of(loop.system, np.geomspace(*omega_range, 2000))
    crossing = np.flatnonzero((np.sign(h.imag[:-1]) != np.sign(h.imag[1:])) & (h.real[:-1] < 0.0))
    gain = float(np.abs(h[crossing]).max()) if crossing.size else float(np.abs(h).max())
    threshold = element.threshold
    drive = getattr(element, "limit", None) or getattr(element, "level", None)
    if drive is None:
        return (threshold * (1.0 + 1e-6), 1e4 * threshold)
    upper = 10.0 * 4.0 * drive * max(gain, 1.0) / math.pi
    lower = threshold * (1.0 + 1e-6) if threshold > 0.0 else (drive * (1.0 + 1e-9) if hasattr(element, "limit")
                                                              else 1e-6 * upper)
    return (lower, max(upper, 10.0 * lower))


def _harmonic_seed(loop, amplitude, omega):
    """The state of a DF cycle at its section ``y = l`` (rising), its mode, and ``l``.

    ``y = A sin(phi)``, the element's first harmonic ``N A`` and H's steady response to
    it: ``x = Im[(jw I - A)^-1 B (-N A) e^{j phi}]``; the element's mode and memory from
    its automaton driven along the sine over one period.
    """
    element = loop.element
    level = _section_level(element, amplitude)
    phase = math.asin(level / amplitude)
    n = complex(np.asarray(element.describing_function(amplitude, omega)).reshape(-1)[0])
    resolvent = np.linalg.solve(1j * omega * np.eye(loop.a.shape[0]) - loop.a, loop.b)
    x = np.imag(resolvent * (-n * amplitude) * np.exp(1j * phase))
    mode, m = _on_sine(element, amplitude, phase)
    return loop.state_of(x, m), mode, level


def _run_seed(run):
    """``(state, mode, period, level)`` on a run's last full oscillation: the sample after its last-but-one
    upward crossing of the mean of its second half, the crossings' spacing as the period."""
    half = run.y[run.y.size // 2:]
    mean = half.mean()
    up = np.flatnonzero((run.y[:-1] < mean) & (run.y[1:] >= mean))
    up = up[up >= run.y.size // 2]
    if up.size < 3:
        raise OrbitNotFound(f"{run.model}: the run crosses its mean fewer than three times in its second half: "
                            "no oscillation to shoot from")
    i, j = up[-2] + 1, up[-1] + 1
    return run.states[i].copy(), int(run.modes[i]), float(run.time[j] - run.time[i]), float(run.y[i])


def _section_level(element, amplitude):
    """The level ``l`` of the section ``y = l``, rising: 0 unless a switch sits there (then A / 2)."""
    levels = {round(abs(guard.coefficients[3]), 12) for mode in element.modes for guard in mode.guards
              if guard.coefficients[1] == guard.coefficients[2] == 0.0}
    return 0.5 * amplitude if 0.0 in levels else 0.0


def _on_sine(element, amplitude, phase, samples=4096):
    """The element's mode and memory at ``phase`` of ``y = A sin``, driven from one period before."""
    phases = np.linspace(-0.5 * math.pi, phase + 2.0 * math.pi, samples)
    y, dy = amplitude * np.sin(phases), amplitude * np.cos(phases)
    m = y[0] + 0.5 * getattr(element, "width", 0.0)
    mode = element.mode_at(y[0], 1.0, m, branch=-1)  # at the trough, rising
    for k in range(1, samples):
        m += element.modes[mode].rate * (y[k] - y[k - 1])
        for guard in element.modes[mode].guards:
            g_y, g_dy, g_m, g_0 = guard.coefficients
            if guard.direction * (g_y * y[k] + g_dy * dy[k] + g_m * m + g_0) > 0.0:
                mode = guard.target
                break
    return mode, m


@dataclasses.dataclass(frozen=True, eq=False)
class LureSimulation:
    """The Lur'e loop in time: ``y`` and the element's output ``F`` on a uniform grid.

    Attributes
    ----------
    model : str
        The element's label.
    time, y, output : ndarray
        s; the element's input and output.
    states : ndarray, shape (samples, size)
        The augmented state ``X = [x, m]``.
    modes : ndarray of int
        The element's mode at each sample (index into the element's ``modes``).
    diverged : bool
        The run grew past 1e100 and stopped there (the samples end before ``t_end``).
    switches : int
        The element's switches over the run (located exactly, between the samples).
    """

    model: str
    time: np.ndarray
    y: np.ndarray
    output: np.ndarray
    states: np.ndarray = dataclasses.field(repr=False)
    modes: np.ndarray = dataclasses.field(repr=False)
    diverged: bool = False
    switches: int = 0

    def __repr__(self):
        ran = f"diverged at {self.time[-1]:.4g} s" if self.diverged else f"{self.time[-1]:.4g} s"
        return f"<LureSimulation {self.model}: {ran}, y in [{self.y.min():.4g}, {self.y.max():.4g}]>"

    def to_dict(self):
        """JSON-ready: the model, whether it diverged and the sampled signals."""
        return json_ready({"model": self.model, "diverged": self.diverged, "switches": self.switches,
                           "time": self.time, "y": self.y, "output": self.output})

    def plot(self, ax=None):
        """y and the element's output F against time, one panel each."""
        fig, axes = axes_or_new(ax, (2, 1), sharex=True, figsize=(7.0, 4.5), layout="constrained")
        axes = np.ravel(axes)
        axes[0].plot(self.time, self.y, lw=1.0)
        axes[0].set_ylabel("y (element input)")
        axes[1].plot(self.time, self.output, lw=1.0, color="C1")
        axes[1].set_ylabel("F (element output)")
        axes[1].set_xlabel("time (s)")
        axes[0].set_title(f"Lur'e loop with {self.model}")
        return ResultPlot(fig, axes)


@dataclasses.dataclass(frozen=True, eq=False)
class LureOrbit:
    """A periodic orbit of a Lur'e loop, exact, with its Floquet multipliers.

    Attributes
    ----------
    model : str
        The element's label.
    period, omega : float
        s and rad/s.
    amplitude : float
        First-harmonic amplitude of y (the DF's A), y's unit.
    output_amplitude : float
        First-harmonic amplitude of the element's output F.
    peak : float
        Half the orbit's swing, ``(max y - min y) / 2``.
    multipliers : ndarray of complex
        The Floquet multipliers less the trivial one (along the flow), by decreasing modulus.
    stable : bool
        All multipliers inside the unit circle.
    state, mode, level : ndarray, int, float
        The augmented state where the orbit crosses the section ``y = level`` rising, and
        the element's mode there.
    switches : tuple of (float, str, str)
        Time in the period and the modes before and after, of every switch.
    residual : float
        ``|X(T) - X(0)|`` at the solution, relative to the state's scale.
    """

    model: str
    period: float
    amplitude: float
    output_amplitude: float
    peak: float
    multipliers: np.ndarray
    state: np.ndarray = dataclasses.field(repr=False)
    mode: int = 0
    level: float = 0.0
    switches: tuple = dataclasses.field(repr=False, default=())
    residual: float = 0.0
    loop: object = dataclasses.field(repr=False, default=None)

    @property
    def omega(self):
        """rad/s."""
        return 2.0 * math.pi / self.period

    @property
    def stable(self):
        """All nontrivial Floquet multipliers inside the unit circle."""
        return bool(np.all(np.abs(self.multipliers) < 1.0))

    @property
    def max_multiplier(self):
        """The largest nontrivial multiplier's modulus."""
        return float(np.abs(self.multipliers).max()) if self.multipliers.size else 0.0

    def __repr__(self):
        kind = "stable" if self.stable else "unstable"
        return (f"LureOrbit({self.model}: A={self.amplitude:.7g}, omega={self.omega:.7g} rad/s, {kind}, "
                f"|mu|max={self.max_multiplier:.4g})")

    def to_dict(self):
        """JSON-ready: amplitude and output amplitude, period, frequency, stability, multipliers."""
        return json_ready({
            "model": self.model, "amplitude": self.amplitude, "output_amplitude": self.output_amplitude,
            "peak": self.peak, "period": self.period, "omega": self.omega, "stable": self.stable,
            "multipliers": [[float(z.real), float(z.imag)] for z in self.multipliers],
            "switches": [list(switch) for switch in self.switches], "residual": self.residual,
        })

    def waveform(self, samples=512):
        """``(t, y, F)`` over one period from the section, exact."""
        with single_threaded_blas():
            return self._waveform(samples)

    def _waveform(self, samples):
        """:meth:`waveform` (BLAS on one thread)."""
        flow = _Flow(self.loop)
        times = np.linspace(0.0, self.period, samples)
        mode, state = self.mode, self.state
        y, output = np.empty(samples), np.empty(samples)
        y[0], _, _, output[0] = self.loop.signals(mode, state)
        for i in range(1, samples):
            mode, state, _ = flow.advance(mode, state, times[i] - times[i - 1])
            y[i], _, _, output[i] = self.loop.signals(mode, state)
        return times, y, output

    def plot(self, ax=None):
        """One period of y and of the element's output F against time, and F against y (the element's loop)."""
        figure, axes = axes_or_new(ax, (1, 2), figsize=(10.0, 3.8), layout="constrained",
                                   gridspec_kw={"width_ratios": (2, 1)})
        axes = np.ravel(axes)
        t, y, output = self.waveform()
        axes[0].plot(t, y, label="y (element input)")
        axes[0].plot(t, output, label="F (element output)")
        axes[0].set_xlabel("time from the section (s)")
        axes[0].legend(loc="upper right", fontsize="small")
        axes[1].plot(y, output, color="C2")
        axes[1].set_xlabel("y")
        axes[1].set_ylabel("F")
        kind = "stable" if self.stable else "unstable"
        axes[0].set_title(f"exact orbit, {self.model}, {kind}\nA = {self.amplitude:.4g}, w = {self.omega:.4g} rad/s, "
                          f"|mu| max {self.max_multiplier:.3g}", fontsize="medium")
        return ResultPlot(figure, axes)


def _period_map(flow, state, mode, period):
    """``(X(T), mode at T, monodromy, switches)`` from ``state`` in ``mode`` over ``period``."""
    events = []
    end_mode, end, mono = flow.advance(mode, state, period, events, np.eye(state.size))
    return end, end_mode, mono, events


def _shoot(loop, state, mode, period, level, tol, max_iter):
    """Damped Newton on ``(X(T) - X0, y0 - level)`` over ``(X0, T)`` with the exact Jacobian.

    A step is halved (up to 20 times) until the residual falls and the start stays in
    the element's mode (on its side of every guard).
    """
    flow = _Flow(loop)
    flow.step = min(flow.step, period / _STEPS_PER_PERIOD)
    y_row = flow.systems[mode][2]
    size = state.size

    def evaluate(trial, trial_period):
        if trial_period <= 0.0 or any(direction * (row @ trial + constant) > 1e-9 * _norm(trial)
                                      for row, constant, direction, _ in flow.guards[mode]):
            return None
        try:
            end, end_mode, mono, _ = _period_map(flow, trial, mode, trial_period)
        except (OrbitNotFound, _Overflow, _Chattering):
            return None
        residual = np.append(end - trial, y_row @ trial - level)
        jacobian = np.zeros((size + 1, size + 1))
        jacobian[:size, :size] = mono - np.eye(size)
        jacobian[:size, size] = flow.field(end_mode, end)
        jacobian[size, :size] = y_row
        return residual, jacobian

    size0 = _norm(state)
    current = evaluate(state, period)
    if current is None:
        raise OrbitNotFound(f"{loop.label}: the seed's period map does not exist (a grazing switch)")
    for iteration in range(max_iter):
        residual, jacobian = current
        try:
            delta = np.linalg.solve(jacobian, -residual)
        except np.linalg.LinAlgError:
            raise OrbitNotFound(f"{loop.label}: the shooting Jacobian is singular at iteration {iteration}") from None
        scale = _norm(state)
        if np.abs(delta[:size]).max() < tol * scale and abs(delta[size]) < tol * period:
            return _orbit(loop, flow, state + delta[:size], mode, period + delta[size], level)
        for _ in range(21):
            trial = evaluate(state + delta[:size], period + delta[size])
            if trial is not None and np.linalg.norm(trial[0]) < np.linalg.norm(residual):
                break
            delta = 0.5 * delta
        else:
            raise OrbitNotFound(f"{loop.label}: shooting stalled at iteration {iteration} (residual "
                                f"{np.linalg.norm(residual) / scale:.2e} of the state): no step lowers it")
        state, period, current = state + delta[:size], period + delta[size], trial
        if _norm(state) < 1e-6 * size0:
            raise OrbitNotFound(f"{loop.label}: shooting collapsed onto the rest (the state fell to "
                                f"{_norm(state) / size0:.1e} of the seed's): no orbit near this seed")
    raise OrbitNotFound(f"{loop.label}: shooting did not converge in {max_iter} Newton steps (last correction "
                        f"{np.abs(delta[:size]).max() / _norm(state):.2e} of the state, "
                        f"{abs(delta[size]) / period:.2e} of the period)")


def _norm(state):
    """The state's scale: its largest entry (never 0)."""
    return max(float(np.abs(state).max()), 1e-300)


def _orbit(loop, flow, state, mode, period, level):
    """The orbit's figures at the converged ``(X0, T)``: multipliers, first harmonics, switches."""
    end, end_mode, mono, events = _period_map(flow, state, mode, period)
    if end_mode != mode:
        raise OrbitNotFound(f"{loop.label}: the orbit ends in the element's mode "
                            f"'{loop.element.modes[end_mode].name}', not '{loop.element.modes[mode].name}'")
    multipliers = np.linalg.eigvals(mono)
    trivial = int(np.argmin(np.abs(multipliers - 1.0)))
    others = np.delete(multipliers, trivial)
    others = others[np.argsort(-np.abs(others))]
    y1, f1, mean, peak = _harmonics(loop, flow, state, mode, period, events)
    names = [spec.name for spec in loop.element.modes]
    return LureOrbit(
        model=loop.label, period=float(period), amplitude=float(abs(y1)), output_amplitude=float(abs(f1)),
        peak=peak, multipliers=others, state=state, mode=mode, level=level,
        switches=tuple((float(t), names[a], names[b]) for t, a, b in events),
        residual=float(np.abs(end - state).max() / max(np.abs(state).max(), 1e-300)), loop=loop,
    )


def _harmonics(loop, flow, state, mode, period, events, pieces=64):
    """First harmonics of y and F, y's mean and its half swing ``(max y - min y) / 2``, by Gauss-Legendre on
    every smooth piece; the extremes from the nodes and the switches (a cusp's), refined by bounded Brent on
    the exact flow."""
    omega = 2.0 * math.pi / period
    bounds = sorted({0.0, period, *(t for t, _, _ in events)})
    start = (mode, state)
    y1 = f1 = 0.0j
    mean = 0.0
    times, values = [], []
    for t0, t1 in zip(bounds[:-1], bounds[1:]):
        times.append(t0)  # the switch itself: a cusp's extreme sits there
        values.append(float(loop.signals(mode, state)[0]))
        edges = np.linspace(t0, t1, max(2, int(math.ceil(pieces * (t1 - t0) / period)) + 1))
        for a, b in zip(edges[:-1], edges[1:]):
            nodes = 0.5 * (a + b) + 0.5 * (b - a) * _NODES
            weights = 0.5 * (b - a) * _WEIGHTS
            for t, w in zip(nodes, weights):
                at, point, _ = flow.advance(mode, state, t - a)
                y, _, _, output = loop.signals(at, point)
                rotation = np.exp(-1j * omega * t)
                y1 += w * y * rotation
                f1 += w * output * rotation
                mean += w * y
                times.append(t)
                values.append(y)
            mode, state, _ = flow.advance(mode, state, b - a)
    extremes = [_extreme(loop, flow, start, period, times, values, sign) for sign in (1.0, -1.0)]
    return 2.0 * y1 / period, 2.0 * f1 / period, mean / period, 0.5 * (extremes[0] - extremes[1])


def _extreme(loop, flow, start, period, times, values, sign):
    """``max y`` (``sign`` 1) or ``min y`` (-1) over the orbit from ``start``: the extreme node, refined by Brent."""
    best = int(np.argmax(sign * np.asarray(values)))
    reach = period / 64

    def negated(t):
        at, point, _ = flow.advance(*start, t % period)
        return -sign * loop.signals(at, point)[0]

    found = scipy.optimize.minimize_scalar(negated, bounds=(times[best] - reach, times[best] + reach),
                                           method="bounded", options={"xatol": 1e-12 * period})
    return sign * max(-found.fun, sign * values[best])
