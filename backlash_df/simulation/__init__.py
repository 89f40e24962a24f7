"""Time simulation of drives with backlash: one kernel pair under every loop, rig-level runs, cycle measurement.

The drive is the loop cut at the backlash, a :class:`~backlash_df.system.LinearPart`
(its equations are in :mod:`backlash_df.system`), closed by the shaft torque
``T = law(theta_d, dtheta_d [, theta_b])``.  External inputs ``w(t)`` are sampled on
the output grid, or at half steps when given as functions of time; the delayed
signal ``u_d`` is interpolated between output samples.  The open-loop two-mass drive
(:func:`~backlash_df.system.two_mass_system`), the PI loops of :mod:`backlash_df.loops`
and the replay of measured data all use this form.

The package has one module per floor:

* ``_kernels``: the two compiled kernels (private);
* :mod:`~backlash_df.simulation.linear`: :func:`simulate_linear` of any linear part,
  :class:`SimulationResult`, :func:`simulate_two_mass`, :func:`default_step`;
* :mod:`~backlash_df.simulation.cycles`: :func:`measure_limit_cycle` and
  :class:`MeasuredCycle`, what a run settled to;
* :mod:`~backlash_df.simulation.rig`: :func:`simulate_rig` (public as
  :func:`backlash_df.simulate`) and :func:`simulated_limit_cycle`, runs of a rig's loop;
* :mod:`~backlash_df.simulation.record`: a rig's loop run on recorded inputs, written as
  a measurement record and compared with one (``backlash-df simulate``).  It reads the
  record format of :mod:`backlash_df.identify`, which stands on this package, so this
  ``__init__`` does not import it; :func:`backlash_df.simulate` is its ``simulate``.

Integration runs on a fixed grid with the law's *mode* frozen over each step
(free, rubber band, steel contact; see :mod:`backlash_df.models`); a change of
mode at the end of a step is located by bisection and the step is split there.
So the jump of the phase plane law at theta*, and the dead-zone's jump at
``|theta_d| = alpha``, are crossed exactly instead of being smeared or
chattered over.  Contact of the phase plane law, once made at theta*, holds
until the release condition of Theorem 1, as in the paper's derivation of (20)
(``backlash_df._laws.held_mode``): read as a memoryless function, (20)
lets a strongly damped contact slide along the jump at theta* with an event
every few nanoseconds.

Two kernels share these rules:

* **Exact discretisation** when the loop is linear inside every mode: the
  dead-zone family (24)-(27), the phase plane law (19)-(23) and the exact model
  (1), (14), with viscous and Coulomb friction (not a breakaway, nor dry friction
  with a torque limit).  In contact ``T = k (theta_d -+ alpha) + c
  dtheta_d``, free ``T = 0`` with the exact model's ``dtheta_b/dt = (k / c)
  (theta_d - theta_b) + dtheta_d``; inputs and the delayed signal are quadratic
  in time over a step (through their samples at 0, dt/2, dt).  So one step is a
  product with ``exp(M dt)`` of an augmented state matrix, exact between events
  whatever the step and stable for any ``c / k``; the bisection walks a ladder
  of ``exp(M dt 2^-j)`` (``_switching.exp_ladder``).  Only a dead
  time (its interpolation between samples) or inputs that are not quadratic over
  a step leave an error depending on dt.
* **Classical RK4** otherwise (the rubber band (36), elasto-backlash, a breakaway
  friction, dry friction with a torque limit, the diagnosis' smoothed friction),
  every stage of an unsplit step on an input sample; the exact model's theta_b
  by the exponential step ``_laws.exact_step``.

Dry friction that sticks (a rig's ``[friction]``, :class:`~backlash_df.system.Sticking`)
adds a third kind of mode, each rubbing side's: sliding forward, sliding backward, stuck.
A sliding side whose speed crosses zero, and a stuck side whose holding torque leaves its
static level, end the mode; the change is located by the same bisection, the speed set
to zero where the side sticks, and while stuck its speed's rate is held at zero by the
friction that holds it (recorded as :attr:`SimulationResult.friction_mode`).  With
Coulomb friction alone every such mode is affine (sliding: a constant torque; stuck: the
field projected onto the zero-speed surface), and the exact kernel steps it, each
backlash mode's ladders one per combination of the sides' modes
(``linear._rubbing_matrices``); a breakaway's Stribeck decay is not affine and runs on
RK4, with the same stick logic.
"""

from .cycles import MeasuredCycle, measure_limit_cycle
from .linear import MAX_STEPS, SimulationResult, default_step, simulate_linear, simulate_two_mass
from .rig import initial_state, simulate_rig, simulated_limit_cycle

__all__ = [
    "SimulationResult",
    "simulate_linear",
    "simulate_two_mass",
    "default_step",
    "MAX_STEPS",
    "MeasuredCycle",
    "measure_limit_cycle",
    "simulate_rig",
    "simulated_limit_cycle",
    "initial_state",
]
