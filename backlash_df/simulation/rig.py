"""Closed-loop runs of a rig's loop, and runs until the motion has settled."""

import numpy as np

from ..loops import drive_loop
from ..models import BacklashModel
from ..system import lti_linear_part
from .cycles import measure_limit_cycle
from .linear import default_step, longest_run, simulate_linear, timed_inputs

__all__ = ["simulate_rig", "simulated_limit_cycle", "initial_state"]


def initial_state(system, initial=None, kick=0.0):
    """Initial state of a run: named values, plus the least-norm state with theta_d = 0, dtheta_d = kick.

    Parameters
    ----------
    system : LinearPart
    initial : dict, optional
        Values by state name (rad, rad/s, ...); a name the system lacks is a ``ValueError``.
    kick : float
        Initial rate dtheta_d, rad/s (for the PI loop: motor and load speeds at +-kick/2).

    Returns
    -------
    ndarray, shape (n,)
    """
    rows = np.array([system.c_x, system.c_v])
    z0 = np.linalg.pinv(rows) @ np.array([0.0, float(kick)])
    for name, value in (initial or {}).items():
        if name not in system.state_names:
            raise ValueError(f"initial: no state {name!r}; states are: {', '.join(system.state_names)}")
        z0[system.state_names.index(name)] = float(value)
    return z0


def simulate_rig(rig, model=None, *, t_end=20.0, dt=None, speed_reference=0.0, load_torque=None,
                 initial=None, kick=0.0, linear=None, theta_b0=0.0):
    """Closed-loop time simulation of a rig's PI speed loop with a backlash torque law.

    Public as :func:`backlash_df.simulate` (given no recorded inputs nor a record to
    compare with: :func:`~backlash_df.simulation.record.simulate`).  The loop is that of
    :mod:`backlash_df.loops` (states ``theta_d``, ``motor_speed``,
    ``load_speed``, ``integrator`` and, when present, ``filtered_speed`` and
    ``motor_torque``), integrated by :func:`~backlash_df.simulation.simulate_linear`.

    Parameters
    ----------
    rig : Rig
        Plant and ``[controller]`` (the shaft parameters build ``model`` if a name).
    model : str or BacklashModel, optional
        Torque law (default: the rig's ``[model] backlash``); the exact model included.
    t_end : float
        Simulated time, s.
    dt : float, optional
        Step, s (default :func:`default_step`).
    speed_reference, load_torque : float or callable
        r (rad/s) and T_l (N m): constants or functions of time (default
        ``load_torque``: the rig's ``[load] torque``).
    initial : dict, optional
        Initial values by state name, e.g. ``{"motor_speed": 0.5}``; others 0.
    kick : float
        Initial rate dtheta_d (rad/s) added as the least-norm state with
        ``theta_d = 0`` (for the PI loop: motor and load speeds at +-kick/2).
    linear : control.LTI, optional
        A user's linear part G (shaft torque -> -theta_d) replacing the rig's loop;
        then the loop has no external inputs and ``initial`` names ``x0, x1, ...``.
    theta_b0 : float
        Initial backlash angle of the exact model, rad (``+-alpha`` on a flank).

    Returns
    -------
    SimulationResult

    Examples
    --------
    >>> from backlash_df import rig_from_dict, simulate
    >>> rig = rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
    ...     "damping": 3.0, "half_gap": 0.05}, "controller": {"kp": 30.0, "ti": 0.5, "feedback": "motor"}})
    >>> result = simulate(rig, "phase-plane", t_end=1.0, initial={"motor_speed": 1.0})
    >>> result.state_names
    ('theta_d', 'motor_speed', 'load_speed', 'integrator')
    """
    if not isinstance(model, BacklashModel):
        model = rig.make_model(model)
    system = drive_loop(rig, dry_friction=True).linear_part() if linear is None else lti_linear_part(linear)
    dt = default_step(system, model) if dt is None else dt
    z0 = initial_state(system, initial, kick)
    load_torque = rig.load.torque if load_torque is None else load_torque
    inputs = timed_inputs(speed_reference, load_torque) if system.E.shape[1] == 2 else None
    return simulate_linear(system, model, t_end, dt, inputs=inputs, z0=z0, theta_b0=theta_b0)


def _divergence_bound(rig, model, load_torque=None):
    """The largest ``|theta_d|`` (rad) of a run that has not diverged: 1e3 times the loop's own scale.

    That scale is the larger of the gap ``alpha`` and the twist the shaft takes to carry
    the torque limit and the load torque, ``(L + |T_l|) / k``: a near-rigid shaft with a tiny
    gap hunts on its torque limit at thousands of gaps of twist, a cycle and not a runaway
    (:func:`~backlash_df.simulation.measure_limit_cycle`'s default is ``1e3 alpha``).

    Parameters
    ----------
    rig : Rig
    model : BacklashModel
        The law simulated (its shaft's ``k`` and ``alpha``).
    load_torque : float, optional
        N m, the run's constant load torque (default the rig's).
    """
    torque = rig.controller.torque_limit if rig.controller is not None else 0.0
    torque += abs(rig.load.torque if load_torque is None or not np.isscalar(load_torque) else load_torque)
    twist = torque / model.stiffness if model.stiffness > 0.0 else 0.0
    return 1e3 * max(model.half_gap, twist)


def simulated_limit_cycle(rig, model=None, *, t_end=20.0, max_t_end=160.0, dt=None, periods=6, rtol=1e-3, **kwargs):
    """Simulate until a steady state and measure the limit cycle.

    Runs :func:`simulate_rig` for ``t_end`` and doubles it (going on from the
    run's end, :meth:`~.linear.SimulationResult.continued`) until :func:`measure_limit_cycle`
    finds a steady state, or the next run would pass ``max_t_end``; a run of more
    than :data:`~.linear.MAX_STEPS` steps (a stiff loop's fine step) is cut to the
    longest the step allows, which is then the last.  A motion that
    dies out in two successive runs (the second confirming the first) is rest.

    Parameters
    ----------
    rig, model, dt, **kwargs
        As :func:`simulate_rig` (``speed_reference``, ``load_torque``, ``initial``, ``kick``, ``linear``,
        ``theta_b0``).
    t_end, max_t_end : float
        First and largest simulated time, s.
    periods, rtol
        As :func:`measure_limit_cycle`.

    Returns
    -------
    measured : MeasuredCycle
    result : SimulationResult
        The last simulation run.
    """
    measured = None
    result = simulate_rig(rig, model, t_end=t_end, dt=dt, **kwargs)
    bound = _divergence_bound(rig, result.model, kwargs.get("load_torque"))
    while True:
        measured = measure_limit_cycle(result, periods=periods, rtol=rtol, bound=bound, previous=measured)
        longest = longest_run(result.time[1] - result.time[0])
        if measured.settled or 2.0 * t_end > max_t_end or t_end >= longest:
            return measured, result
        t_end = min(2.0 * t_end, longest)
        result = result.continued(t_end)
