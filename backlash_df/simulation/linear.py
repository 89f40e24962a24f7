"""Simulation of a linear part closed through a backlash torque law, and its result.

:func:`simulate_linear` integrates a :class:`~backlash_df.system.LinearPart` with
any law of :func:`~backlash_df.make_model`; :func:`simulate_two_mass` drives the open
two-mass system with given torques; :func:`default_step` picks a step from the loop's
fastest dynamics.  The kernels are those of :mod:`backlash_df.simulation`.
"""

import dataclasses
import math

import numpy as np

from .._json import json_ready
from .._laws import DAMPED_DEAD_ZONE, DEAD_ZONE, EXACT, PHASE_PLANE, REVISED_DEAD_ZONE, RUBBER
from .._switching import THETA_B, UNIT, command_matrices, exp_ladder, holding_rows, mode_matrices, rubbing_matrix
from ..models import BacklashModel, make_model
from ..plotting import ResultPlot, axes_or_new
from ..system import closed_loop_matrix, two_mass_system
from ._kernels import LEVELS, AugmentedCommand, AugmentedFriction, CommandRows, run_exact, run_rk4

__all__ = ["SimulationResult", "simulate_linear", "simulate_two_mass", "timed_inputs", "default_step", "signal_trace",
           "MAX_STEPS"]


@dataclasses.dataclass(frozen=True)
class SimulationResult:
    """Time response of a drive with backlash.

    Attributes
    ----------
    time : ndarray
        Output grid, s.
    states : ndarray
        State trajectory, shape (len(time), n), columns named by ``state_names``.
    theta_d, dtheta_d : ndarray
        Displacement (rad) and its rate (rad/s).
    torque : ndarray
        Shaft torque T (N m).
    theta_b : ndarray
        Backlash angle of the exact model (rad); NaN for static laws.
    mode : ndarray
        Contact mode at each sample (0 free, +-1 rubber band or exact contact,
        +-2 steel contact).
    events : int
        Number of located mode changes (of the backlash and of the command).
    model : BacklashModel
        The torque law simulated.
    state_names : tuple of str
    command : ndarray or None
        With a torque limit: the torque command ``clip(u, -limit, limit)`` at each sample (N m).
    command_mode : ndarray or None
        With a torque limit: the command's mode at each sample
        (``_switching.COMMAND_MODES``: 0 linear, +-1 saturated,
        +-2 the integrator clamped, +-3 sliding on the limit).
    friction_mode : ndarray or None
        With sticking friction (:class:`~backlash_df.system.Sticking`): each side's
        mode at each sample, shape (len(time), sides), columns in the order of
        ``friction_sides``: 0 stuck, +-1 sliding forward or backward.
    friction_sides : tuple of str
        The rubbing sides (``"motor"``, ``"load"``); empty without sticking friction.
    """

    time: np.ndarray
    states: np.ndarray
    theta_d: np.ndarray
    dtheta_d: np.ndarray
    torque: np.ndarray
    theta_b: np.ndarray
    mode: np.ndarray
    events: int
    model: BacklashModel
    state_names: tuple
    command: np.ndarray | None = dataclasses.field(default=None, repr=False)
    command_mode: np.ndarray | None = dataclasses.field(default=None, repr=False)
    friction_mode: np.ndarray | None = dataclasses.field(default=None, repr=False)
    friction_sides: tuple = ()
    _end: "_RunEnd | None" = dataclasses.field(default=None, repr=False, compare=False)

    def continued(self, t_end):
        """The run gone on to ``t_end`` (s) from its last sample: the same, to the bit, as a run to ``t_end``.

        Only the new steps are integrated; the kernel's state at the last sample
        (the exact model's theta_b, the modes, a dead time's history) is carried.

        Raises
        ------
        ValueError
            A run whose inputs were given as an array on its grid, a ``t_end`` not
            beyond the run's, or more than :data:`MAX_STEPS` steps.
        """
        if self._end is None:
            raise ValueError("a run whose inputs are an array on its grid cannot go on: simulate to t_end instead")
        end = self._end
        first = self.time.size - 1
        n_steps = _step_count(t_end, end.dt)
        if n_steps <= first:
            raise ValueError(f"t_end = {t_end!r} s must lie beyond the run's end, {self.time[-1]!r} s")
        outputs = _outputs(n_steps, end.system)
        for array, old in zip(outputs, (self.states, self.torque, self.theta_b, self.mode, self.command_mode,
                                        self.friction_mode, end.hist)):
            if old is not None:
                array[:first + 1] = old
        return _run(end.system, end.model, end.inputs, end.dt, n_steps, outputs, end, first)

    @property
    def backlash_switched(self):
        """Whether the backlash changed mode (a contact or a release) during the run.

        The command's switches (a torque limit) are not counted: a motion that
        saturates the command inside the gap never left the gap.
        """
        if self.command_mode is None:
            return self.events > 0  # every located event is the backlash's
        return bool(np.any(np.diff(self.mode) != 0))

    @property
    def saturated(self):
        """Share of the samples with the torque command on its limit (0 without a limit)."""
        return 0.0 if self.command_mode is None else float(np.mean(self.command_mode != 0))

    def state(self, name):
        """One state's trajectory by name (for example ``"motor_speed"``)."""
        try:
            return self.states[:, self.state_names.index(name)]
        except ValueError:
            raise ValueError(f"no state {name!r}; states are: {', '.join(self.state_names)}") from None

    def __repr__(self):
        limit = "" if self.command_mode is None else f", command saturated {100 * self.saturated:.0f} % of the time"
        return (f"<SimulationResult {self.model.name}: {self.time.size} samples, t = {self.time[0]:g} .. "
                f"{self.time[-1]:g} s, {self.events} mode changes, states {', '.join(self.state_names)}{limit}>")

    def to_dict(self):
        """JSON-ready: the sampled trajectory (s, rad, rad/s, N m), mode codes and event count.

        ``theta_b`` is null for a static law; NaN samples of a diverged run are null.
        """
        return json_ready({
            "model": self.model.name,
            "state_names": list(self.state_names),
            "events": int(self.events),
            "time": self.time.tolist(),
            "states": self.states.tolist(),
            "theta_d": self.theta_d.tolist(),
            "dtheta_d": self.dtheta_d.tolist(),
            "torque": self.torque.tolist(),
            "theta_b": None if self.model.is_static else self.theta_b.tolist(),
            "mode": self.mode.tolist(),
            "command": None if self.command is None else self.command.tolist(),
            "command_mode": None if self.command_mode is None else self.command_mode.tolist(),
            **({} if self.friction_mode is None else {"friction_sides": list(self.friction_sides),
                                                      "friction_mode": self.friction_mode.tolist()}),
        })

    def plot(self, ax=None):
        """theta_d and the shaft torque against time.

        Parameters
        ----------
        ax : sequence of 2 matplotlib Axes, optional

        Returns
        -------
        ResultPlot
            Axes ``[theta_d(t), T(t)]``.
        """
        figure, axes = axes_or_new(ax, (2, 1), sharex=True, figsize=(7, 4.5), layout="constrained")
        axes[0].plot(self.time, self.theta_d)
        axes[0].set_ylabel("theta_d (rad)")
        axes[1].plot(self.time, self.torque)
        axes[1].set_ylabel("shaft torque T (N m)")
        axes[1].set_xlabel("time (s)")
        axes[0].set_title(f"{self.model.name}")
        return ResultPlot(figure, axes)


def _piecewise_affine(system, model):
    """True if the loop is linear within every mode: no smoothed or breakaway friction (Coulomb friction's
    stick and slip are modes, without a torque limit), torque affine in (theta_d, dtheta_d)."""
    if system.friction > 0.0 or system.breakaway > 0.0:
        return False
    sticking = system.sticking
    if sticking is not None and (np.any(sticking.breakaway > 0.0) or system.command is not None):
        return False
    if model.law == RUBBER:
        return model.rubber_thickness == 0.0
    return model.law in (DEAD_ZONE, DAMPED_DEAD_ZONE, REVISED_DEAD_ZONE, PHASE_PLANE, EXACT)


def _simulate_exactly(system, model, w, dt, n_steps, outputs, start, first):
    """Fill the outputs with the exact-discretisation kernel from ``start`` at sample ``first``.

    Returns ``(events, q)``: the events of the steps taken and the kernel's state at the last sample.
    """
    states, torque, theta_b, modes, cmodes, fmodes, hist = outputs
    law = _stepped_law(model)
    varying = [j for j in range(w.shape[1]) if np.ptp(w[:, j]) > 0.0]
    constant = np.delete(w[0], varying)
    matrices = mode_matrices(system, model, law, varying, constant)
    size = matrices.shape[1]
    command = None  # the kernel compiled without the command's code (simulation._kernels)
    if system.command is not None:
        per_mode, u_row, e_row, rates = command_matrices(system, matrices, varying, constant)
        matrices = per_mode.reshape(-1, size, size)
        command = AugmentedCommand(u_row, e_row, rates, float(system.command.limit), system.command.integrator >= 0)
    friction = None  # the kernel compiled without the friction's code
    if system.sticking is not None:
        matrices, friction = _rubbing_matrices(system, matrices)
    ladders = np.stack([exp_ladder(m_aug, dt, LEVELS) for m_aug in matrices])
    if first == 0:
        n = system.A.shape[0]
        q = np.zeros(size)
        q[:n], q[n + THETA_B], q[n + UNIT] = start.state[:n], start.state[n], 1.0  # start.state: [z, theta_b]
    else:
        q = start.state.copy()
    # None: nothing varies over a step, and the kernel is compiled without the inputs' code
    inputs = np.ascontiguousarray(w[:, varying]) if varying or system.delay > 0.0 else None
    events = run_exact(
        ladders, command, law, _law_params(model), inputs, q,
        float(system.delay), system.d, system.c_x, system.c_v, dt, n_steps, states, torque, theta_b, modes, cmodes,
        hist, first, start.mode, start.cmode, friction, start.fmodes.copy(), fmodes,
    )
    return events, q


def _rubbing_matrices(system, matrices):
    """The modes' matrices with Coulomb friction, and the friction as the exact kernel takes it.

    Per backlash mode, one matrix per combination of the rubbing sides' modes (numbered
    ``sum (mode_s + 1) 3^s``, :class:`~backlash_df.simulation._kernels.AugmentedFriction`),
    ``_switching.rubbing_matrix``; each side's holding friction per backlash mode,
    ``_switching.holding_rows``.
    """
    sticking, n = system.sticking, system.A.shape[0]
    size, sides = matrices.shape[1], len(sticking.names)
    columns = np.zeros((sides, size))
    columns[:, :n] = sticking.column
    index = np.array(sticking.index, dtype=np.int64)
    hold = np.stack([holding_rows(m_aug, columns, index) for m_aug in matrices])
    out = [rubbing_matrix(m_aug, columns, index, sticking.coulomb, [(code // 3 ** s) % 3 - 1 for s in range(sides)],
                          n + UNIT)
           for m_aug in matrices for code in range(3 ** sides)]
    return np.stack(out), AugmentedFriction(index, np.ascontiguousarray(sticking.coulomb, dtype=float), hold)


def _stepped_law(model):
    """The law the exact kernel steps: the exact model without damping is the dead-zone (Remark 2)."""
    return DEAD_ZONE if model.law == EXACT and model.damping == 0.0 else model.law


def _law_params(model):
    """The law's ``(k, c, alpha, beta)`` as a tuple of floats: scalars to the kernels, not a counted array."""
    return tuple(model.params.tolist())


def _command_arrays(system):
    """The command as the RK4 kernel takes it (a ``_kernels.CommandRows``), None without a limit
    (the kernel then compiled without the command's code)."""
    command = system.command
    if command is None:
        return None
    return CommandRows(command.column, command.row, command.error, float(command.limit), int(command.integrator))


def _command_trace(system, time, states, w_grid):
    """``clip(u, -limit, limit)`` at every sample (N m), the delayed signals interpolated from the record."""
    command = system.command
    return np.clip(signal_trace(system, command.row, time, states, w_grid), -command.limit, command.limit)


def signal_trace(system, row, time, states, inputs):
    """A signal ``row . [z, w, u_d]`` of a run at every sample: linear in the states, inputs and delayed signals.

    The delayed signals ``u_d = d z(t - delay)`` are interpolated linearly between
    samples (before the run's start, its first sample), as the kernels hold them.

    Parameters
    ----------
    system : LinearPart
    row : ndarray, shape (n + m + k,)
        Over the states, the inputs and the delayed signals (the controller's
        output: :meth:`~backlash_df.loops.DriveLoop.command_row`).
    time : ndarray, shape (N,)
        The run's samples, s.
    states : ndarray, shape (N, n)
    inputs : ndarray, shape (N, m) or (1, m)
        The inputs at the samples (one row: constants).

    Returns
    -------
    ndarray, shape (N,)
    """
    n, m = system.n_states, system.E.shape[1]
    with np.errstate(over="ignore", invalid="ignore"):
        signal = states @ row[:n] + inputs @ row[n:n + m]
        if system.n_delayed:
            signals = states @ system.d.T
            delayed = np.column_stack([np.interp(time - system.delay, time, signals[:, j])
                                       for j in range(system.n_delayed)])
            signal = signal + delayed @ row[n + m:]
    return signal


#: Most steps of one simulation: every sample is stored (about 80 bytes a step), and the
#: verdict and verification need at most 3.2e6 (320 s at the default step of 1e-4 s).
MAX_STEPS = 20_000_000


def longest_run(dt):
    """The longest run (s) at the step ``dt`` (s): :data:`MAX_STEPS` steps, less one against round-off."""
    return (MAX_STEPS - 1) * dt


def simulate_linear(system, model, t_end, dt, inputs=None, z0=None, theta_b0=0.0):
    """Simulate a linear part closed through a backlash torque law.

    Parameters
    ----------
    system : LinearPart
    model : BacklashModel
        Any law from :func:`~backlash_df.make_model`, the exact model included.
    t_end, dt : float
        Final time and output/integration step, s.
    inputs : array_like or callable, optional
        External inputs ``w``: an array of shape (N, m) on the grid
        ``arange(N) * dt`` (N = number of output samples), or a callable
        ``w(t) -> (len(t), m)``, sampled at half steps ``arange(2 N - 1) * dt / 2``
        (the RK4 stage times); a callable of :func:`timed_inputs` whose values are all
        constants is not sampled (two equal rows span the run).  Default: zero.
    z0 : array_like, optional
        Initial state (default zero).
    theta_b0 : float
        Initial backlash angle of the exact model, rad.

    Returns
    -------
    SimulationResult

    Raises
    ------
    ValueError
        A step or duration that is not finite and positive, a step longer than
        the delay, or more than :data:`MAX_STEPS` steps.
    """
    if not (dt > 0.0 and math.isfinite(dt)):
        raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    if not (t_end > 0.0 and math.isfinite(t_end)):
        raise ValueError(f"t_end must be finite and > 0, got {t_end!r}")
    if 0.0 < system.delay < dt:
        raise ValueError(f"dt = {dt!r} s must not exceed the delay {system.delay!r} s")
    n_steps = _step_count(t_end, dt)
    n, m = system.E.shape
    if not (inputs is None or callable(inputs)):
        inputs = np.asarray(inputs, dtype=float)
        if inputs.ndim == 1 and m == 1:
            inputs = inputs[:, None]
        if inputs.shape != (n_steps + 1, m):
            raise ValueError(f"inputs must have shape ({n_steps + 1}, {m}) for channels {system.input_names}, "
                             f"got {inputs.shape}")
    z0 = np.zeros(n) if z0 is None else np.asarray(z0, dtype=float).copy()
    if z0.shape != (n,) or not np.all(np.isfinite(z0)):
        raise ValueError(f"z0 must be {n} finite numbers for states {system.state_names}")
    if abs(theta_b0) > model.half_gap:
        raise ValueError(f"theta_b0 must lie in [-half_gap, half_gap], got {theta_b0!r}")
    start = _RunEnd(system, model, inputs, float(dt), np.append(z0, float(theta_b0)), 0, 0, _no_modes(system), None, 0)
    return _run(system, model, inputs, float(dt), n_steps, _outputs(n_steps, system), start, 0)


def _step_count(t_end, dt):
    """The steps of a run to ``t_end`` (s) at ``dt`` (s); a ``ValueError`` for a duration out of bounds."""
    if not (t_end > 0.0 and math.isfinite(t_end)):
        raise ValueError(f"t_end must be finite and > 0, got {t_end!r}")
    n_steps = int(round(t_end / dt))
    if n_steps < 1:
        raise ValueError(f"t_end = {t_end!r} s must be at least one step dt = {dt!r} s")
    if n_steps > MAX_STEPS:
        raise ValueError(f"t_end = {t_end:g} s at dt = {dt:.3g} s is {n_steps:.3g} steps, more than {MAX_STEPS:.0e}: "
                         f"the loop's fastest dynamics need that step; check the rig's units (stiffness, damping, inertias, kp)")
    return n_steps


def _no_modes(system):
    """The friction modes before a run: none known (the kernel finds them at the start)."""
    return np.zeros(0 if system.sticking is None else len(system.sticking.names), dtype=np.int64)


def _outputs(n_steps, system):
    """The arrays a kernel fills: states, torque, theta_b, modes, command modes, friction modes, delayed signals."""
    return (np.empty((n_steps + 1, system.n_states)), np.empty(n_steps + 1), np.empty(n_steps + 1),
            np.empty(n_steps + 1, dtype=np.int64), np.zeros(n_steps + 1, dtype=np.int64),
            np.zeros((n_steps + 1, _no_modes(system).size), dtype=np.int64), np.zeros((n_steps + 1, system.n_delayed)))


@dataclasses.dataclass(frozen=True)
class _RunEnd:
    """Where a kernel run starts or stopped: its state (``z`` and theta_b; the exact kernel's augmented ``q``),
    modes and delayed-signal history there, with what it needs to go on."""

    system: object
    model: BacklashModel
    inputs: object
    dt: float
    state: np.ndarray
    mode: int
    cmode: int
    fmodes: np.ndarray
    hist: np.ndarray | None
    events: int


def _input_rows(system, inputs, n_steps, dt):
    """The inputs as the kernels take them: two equal rows for constants, else rows on the grid or at half steps."""
    m = system.E.shape[1]
    if inputs is None or getattr(inputs, "constant", None) is not None:
        # constants: two equal rows span the run (the kernels interpolate w over rows spread uniformly)
        w = np.tile(np.zeros(m) if inputs is None else np.asarray(inputs.constant, dtype=float), (2, 1))
        if w.shape != (2, m):
            raise ValueError(f"inputs must be {m} constants for channels {system.input_names}, got {inputs.constant}")
    elif callable(inputs):
        w = np.asarray(inputs(np.arange(2 * n_steps + 1) * (0.5 * dt)), dtype=float).reshape(2 * n_steps + 1, m)
    else:
        w = inputs
    if not np.all(np.isfinite(w)):
        raise ValueError("inputs must be finite")
    return np.ascontiguousarray(w)


def _run(system, model, inputs, dt, n_steps, outputs, start, first):
    """The kernel's run from ``start`` at sample ``first`` to ``n_steps``, into ``outputs``: a SimulationResult."""
    w = _input_rows(system, inputs, n_steps, dt)
    states, torque, theta_b, modes, cmodes, fmodes, hist = outputs
    exactly = _piecewise_affine(system, model)
    if exactly:
        events, state = _simulate_exactly(system, model, w, dt, n_steps, outputs, start, first)
    else:
        n = system.A.shape[0]
        stick = None if system.sticking is None else system.sticking.kernel_rows()
        events = run_rk4(system.kernel_arrays(), _command_arrays(system), stick, model.law, _law_params(model), w,
                         start.state[:n], float(start.state[n]), dt, n_steps, states, torque, theta_b, modes, cmodes,
                         fmodes, hist, first, start.mode, start.cmode, start.fmodes)
        state = np.append(states[-1], theta_b[-1])
    end = _RunEnd(system, model, inputs, dt, state, int(modes[-1]), int(cmodes[-1]), fmodes[-1].copy(), hist,
                  start.events + int(events))
    if model.is_static:
        theta_b[:] = np.nan
    elif exactly and _stepped_law(model) != model.law:  # dead-zone modes 0, +-2 back to the exact model's
        modes[first:] //= 2
        theta_b[:] = np.clip(states @ system.c_x, -model.half_gap, model.half_gap)
    with np.errstate(over="ignore", invalid="ignore"):  # a diverged run is named by measure_limit_cycle
        theta_d, dtheta_d = states @ system.c_x, states @ system.c_v
    time = np.arange(n_steps + 1) * dt
    command = None
    if system.command is not None:
        rows = {2 * n_steps + 1: w[::2], n_steps + 1: w}  # half steps, or the output grid; else the constant rows
        command = _command_trace(system, time, states, rows.get(w.shape[0], w[:1]))
    return SimulationResult(
        time=time,
        states=states,
        theta_d=theta_d,
        dtheta_d=dtheta_d,
        torque=torque,
        theta_b=theta_b,
        mode=modes,
        events=end.events,
        model=model,
        state_names=system.state_names,
        command=command,
        command_mode=None if system.command is None else cmodes,
        friction_mode=None if system.sticking is None else fmodes,
        friction_sides=() if system.sticking is None else system.sticking.names,
        _end=None if isinstance(inputs, np.ndarray) else end,
    )


def simulate_two_mass(plant, model, t_end, dt, motor_torque=0.0, load_torque=0.0, z0=None, theta_b0=0.0):
    """Open-loop two-mass drive with backlash under given external torques.

    Parameters
    ----------
    plant : Plant
        Inertias (and the shaft, unless ``model`` is given as an object).
    model : str or BacklashModel
        A law name (built from ``plant``'s shaft) or a model object.
    t_end, dt : float
        Final time and step, s.
    motor_torque, load_torque : float, array_like or callable
        T_m and T_l (N m): constants, arrays on the grid, or functions of time.
    z0 : array_like, optional
        Initial ``(theta_d, motor_speed, load_speed)``.
    theta_b0 : float
        Initial backlash angle of the exact model, rad.

    Returns
    -------
    SimulationResult
    """
    if isinstance(model, str):
        model = make_model(model, **plant.shaft)
    system = two_mass_system(plant.motor_inertia, plant.load_inertia)

    return simulate_linear(system, model, t_end, dt, inputs=timed_inputs(motor_torque, load_torque), z0=z0,
                           theta_b0=theta_b0)


def timed_inputs(*values):
    """The ``inputs(time)`` of :func:`simulate_linear` for external inputs given one by one.

    Each value is a constant, an array on the time grid, or a function of time;
    the returned function gives them as the columns of an array ``(len(time), len(values))``.
    Where every value is a constant, its attribute ``constant`` holds them, and
    :func:`simulate_linear` stores two rows instead of one per half step.
    """
    def inputs(time):
        columns = []
        for value in values:
            column = value(time) if callable(value) else value
            columns.append(np.broadcast_to(np.asarray(column, dtype=float), time.shape))
        return np.stack(columns, axis=1)

    if not any(callable(value) for value in values) and all(np.ndim(value) == 0 for value in values):
        inputs.constant = tuple(float(value) for value in values)
    return inputs


def default_step(system, model):
    """A step (s) resolving the fastest closed-loop dynamics: ``0.05 / max|eigenvalue|``.

    The eigenvalues are those of the loop with the shaft in full contact
    (``T = k theta_d + c dtheta_d``); the step never exceeds the dead time.
    """
    closed = closed_loop_matrix(system, model.stiffness, model.damping)
    fastest = max(np.abs(np.linalg.eigvals(closed)).max(), 1e-3)
    dt = 0.05 / fastest
    if system.delay > 0.0:
        dt = min(dt, system.delay / math.ceil(system.delay / dt))
    return dt

