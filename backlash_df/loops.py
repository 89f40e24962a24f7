"""The PI speed loop around a two-mass drive: the linear part G(s) seen by the backlash.

The loop of the rig file's ``[controller]`` table (SI units)::

    J_m dw_m/dt = T_m - T           J_l dw_l/dt = T + T_l        dtheta_d/dt = w_m - w_l
    y = w_m or w_l                  measured speed ("feedback" = "motor" or "load")
    y_d(t) = y(t - delay)           dead time on the measurement
    tau_f dy_f/dt = y_d - y_f       first-order speed filter (tau_f = speed_filter)
    dI/dt = r - y_f,  u = kp (r - y_f) + (kp / ti) I           PI speed controller
    tau_l dT_m/dt = u - T_m         first-order torque (current) loop (tau_l = torque_lag)

with speed reference ``r`` and load torque ``T_l`` as external inputs (paper eq. 42
and Figure 3 give the two-mass part).  The filter and lag states exist only when
their time constants are positive.  The backlash closes the loop through the
shaft torque ``T = law(theta_d, dtheta_d)``.  With ``r`` and ``T_l`` constant the
loop is invariant to a common speed offset, so a limit cycle lives around the
operating point "both speeds at ``r``" with the shaft transmitting ``-T_l``; with
``T_l = 0`` it is centred in the gap (``bias = 0``).

Cutting the loop at the backlash, the linear part from ``T`` to ``-theta_d`` is
``G(s)``, so that ``T = N(A, w) theta_d`` gives the harmonic-balance equation
``1 + G(jw) N(A, w) = 0``.  With ``K(s) = kp (1 + 1 / (ti s)) e^{-s delay} /
((tau_f s + 1)(tau_l s + 1))``, ``P_m = 1 / (J_m s)``, ``P_l = 1 / (J_l s)``:

* motor feedback: ``G = (P_m / (1 + K P_m) + P_l) / s``,
* load feedback: ``G = (P_m (1 + K P_l) + P_l) / s``.

The dead time is exact in :meth:`DriveLoop.frequency_response` and
:meth:`DriveLoop.frd`; a Pade approximation appears only in
:meth:`DriveLoop.transfer_function`, where a rational model is needed.
"""

import dataclasses

import numpy as np

from .system import LinearPart, closed_loop_matrix, frequency_response

__all__ = ["DriveLoop", "drive_loop", "frequency_response_of"]


@dataclasses.dataclass(frozen=True)
class DriveLoop:
    """The PI speed loop of a rig: G(s), its frequency response and its time-domain form.

    Attributes
    ----------
    plant : Plant
        Inertias (the shaft itself is the backlash element, outside G).
    controller : Controller
        PI gains, feedback choice, filter, torque lag and dead time.

    Examples
    --------
    >>> from backlash_df import Plant, Controller
    >>> loop = DriveLoop(Plant(0.4, 5.6, 5895.0, 0.05), Controller(kp=30.0, ti=0.5))
    >>> g = loop.transfer_function()
    >>> bool(abs(g(2j) - loop.frequency_response(2.0)) < 1e-12 * abs(g(2j)))
    True
    """

    plant: "object"
    controller: "object"

    # ------------------------------------------------------------------ blocks

    def controller_tf(self, pade_order=None):
        """K(s): PI, speed filter, torque lag and (Pade-approximated) dead time.

        Parameters
        ----------
        pade_order : int, optional
            Order of the Pade approximation of the dead time.  Required when the
            rig has a delay (a rational model cannot hold it exactly).

        Returns
        -------
        control.TransferFunction
        """
        ctl = self.controller
        k = self._rational_controller()
        if ctl.delay > 0.0:
            if pade_order is None:
                raise ValueError(
                    f"the loop has a dead time of {ctl.delay!r} s: pass pade_order for a rational model, "
                    "or use frequency_response / frd for the exact one"
                )
            import control as ct  # lazy: python-control takes a second to import

            num, den = ct.pade(ctl.delay, int(pade_order))
            k = k * ct.tf(num, den)
        return k

    def _rational_controller(self):
        """PI, filter and lag: K(s) without the dead time."""
        import control as ct

        ctl = self.controller
        s = ct.tf("s")
        k = ctl.kp * (1 + 1 / (ctl.ti * s))
        if ctl.speed_filter > 0.0:
            k = k / (ctl.speed_filter * s + 1)
        if ctl.torque_lag > 0.0:
            k = k / (ctl.torque_lag * s + 1)
        return k

    def _assemble(self, k, s):
        """G from the blocks: ``k`` is K and ``s`` the Laplace variable, as TFs or FRDs."""
        p_m = 1 / (self.plant.motor_inertia * s)
        p_l = 1 / (self.plant.load_inertia * s)
        if self.controller.feedback == "motor":
            import control as ct

            return (ct.feedback(p_m, k) + p_l) / s
        return (p_m * (1 + k * p_l) + p_l) / s

    def transfer_function(self, pade_order=None):
        """G(s) from shaft torque T (N m) to -theta_d (rad) as a python-control TF.

        Parameters
        ----------
        pade_order : int, optional
            Pade order for the dead time; required only if the rig has one.

        Returns
        -------
        control.TransferFunction
            Exact without dead time; with one, G with ``e^{-s delay}`` replaced by
            its Pade approximation.
        """
        import control as ct

        g = self._assemble(self.controller_tf(pade_order), ct.tf("s"))
        return ct.minreal(g, verbose=False)

    def frd(self, omega):
        """G(jw) as a python-control ``FrequencyResponseData``, dead time exact.

        Parameters
        ----------
        omega : array_like
            Frequencies, rad/s (> 0).

        Returns
        -------
        control.FrequencyResponseData
        """
        import control as ct

        omega = _frequencies(omega)
        delay = self.controller.delay
        k = ct.frd(self._rational_controller(), omega)
        if delay > 0.0:
            k = k * ct.frd(np.exp(-1j * omega * delay), omega)
        s = ct.frd(1j * omega, omega)
        return self._assemble(k, s)

    def frequency_response(self, omega):
        """G(jw), complex, from the state-space loop with the dead time exact.

        :func:`backlash_df.system.frequency_response` of :meth:`linear_part`;
        vectorised over ``omega``.

        Parameters
        ----------
        omega : array_like
            Frequencies, rad/s (> 0); any shape.

        Returns
        -------
        ndarray of complex
            Same shape as ``omega``.
        """
        return frequency_response(self.linear_part(), omega)

    # ------------------------------------------------------------------ time domain

    def linear_part(self):
        """The same loop as a :class:`~backlash_df.system.LinearPart`: the loop cut at the backlash.

        States ``theta_d`` (rad), ``motor_speed``, ``load_speed`` (rad/s),
        ``integrator`` (rad, the integral of the speed error), then
        ``filtered_speed`` (rad/s) if ``speed_filter > 0`` and ``motor_torque``
        (N m, torque-loop output) if ``torque_lag > 0``.  Inputs
        ``speed_reference`` (rad/s) and ``load_torque`` (N m).  A dead time
        delays the measured speed (kernel row ``d``, entering by ``e_d``).

        Returns
        -------
        LinearPart
        """
        ctl, plant = self.controller, self.plant
        names = ["theta_d", "motor_speed", "load_speed", "integrator"]
        if ctl.speed_filter > 0.0:
            names.append("filtered_speed")
        if ctl.torque_lag > 0.0:
            names.append("motor_torque")
        n = len(names)
        idx = {name: i for i, name in enumerate(names)}
        # each signal is a row over [z (n), r, T_l, T, y_delayed]
        width = n + 4
        R, TL, T, YD = n, n + 1, n + 2, n + 3

        def unit(i, scale=1.0):
            row = np.zeros(width)
            row[i] = scale
            return row

        measured = idx["motor_speed" if ctl.feedback == "motor" else "load_speed"]
        y_delayed = unit(YD) if ctl.delay > 0.0 else unit(measured)
        y_f = unit(idx["filtered_speed"]) if "filtered_speed" in idx else y_delayed
        error = unit(R) - y_f
        u = ctl.kp * error + ctl.ki * unit(idx["integrator"])
        motor_torque = unit(idx["motor_torque"]) if "motor_torque" in idx else u

        rates = {
            "theta_d": unit(idx["motor_speed"]) - unit(idx["load_speed"]),
            "motor_speed": (motor_torque - unit(T)) / plant.motor_inertia,
            "load_speed": (unit(T) + unit(TL)) / plant.load_inertia,
            "integrator": error,
        }
        if "filtered_speed" in idx:
            rates["filtered_speed"] = (y_delayed - y_f) / ctl.speed_filter
        if "motor_torque" in idx:
            rates["motor_torque"] = (u - motor_torque) / ctl.torque_lag
        table = np.array([rates[name] for name in names])
        return LinearPart(
            A=table[:, :n],
            b=table[:, T],
            E=table[:, [R, TL]],
            c_x=unit(idx["theta_d"])[:n],
            c_v=rates["theta_d"][:n],
            state_names=tuple(names),
            input_names=("speed_reference", "load_torque"),
            delay=ctl.delay,
            d=unit(measured)[:n],
            e_d=table[:, YD],
        )

    def linear_poles(self, stiffness, damping=0.0):
        """Closed-loop poles with the backlash replaced by the spring ``T = k theta_d + c dtheta_d``.

        Parameters
        ----------
        stiffness, damping : float
            k (N m/rad) and c (N m s/rad).

        Returns
        -------
        ndarray of complex
            Eigenvalues (1/s) of the delay-free loop; raises if the loop has a dead time.
        """
        part = self.linear_part()
        if part.delay > 0.0:
            raise ValueError("linear_poles: the loop has a dead time (infinitely many poles); use a Pade model")
        return np.linalg.eigvals(closed_loop_matrix(part, stiffness, damping))


def drive_loop(rig):
    """The :class:`DriveLoop` of a rig (needs its ``[controller]`` table)."""
    return DriveLoop(rig.plant, rig.require_controller())


def frequency_response_of(linear, omega):
    """G(jw) of a :class:`DriveLoop`, a python-control LTI or a callable ``omega -> G``.

    Parameters
    ----------
    linear : DriveLoop, control.LTI or callable
    omega : array_like
        rad/s.

    Returns
    -------
    ndarray of complex, shape of ``omega``
    """
    omega = np.asarray(omega, dtype=float)
    if isinstance(linear, DriveLoop):
        return linear.frequency_response(omega)
    import control as ct  # only a user's LTI needs python-control

    if isinstance(linear, ct.LTI):
        if linear.ninputs != 1 or linear.noutputs != 1:
            raise ValueError("the linear part must be SISO (shaft torque -> -theta_d)")
        flat = omega.reshape(-1)
        if isinstance(linear, ct.FrequencyResponseData):
            values = linear.eval(flat)
        else:
            values = linear(1j * flat)
        return np.asarray(values, dtype=complex).reshape(omega.shape)
    if callable(linear):
        return np.broadcast_to(np.asarray(linear(omega), dtype=complex), omega.shape)
    raise ValueError(f"cannot take a frequency response of {type(linear).__name__}; pass a DriveLoop, an LTI or a callable")


def _frequencies(omega):
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    if omega.ndim != 1 or not np.all(np.isfinite(omega)) or np.any(omega <= 0.0):
        raise ValueError("omega must be a 1-D array of finite frequencies > 0 rad/s")
    return omega
