"""The load at which a loaded loop's limit cycle disappears.

A constant torque ``T_l`` on the load (``[load] torque``, N m) shifts the
oscillation of the shaft angle to ``theta_d = b + A sin(w t)``.  The PI
integrator removes any mean speed error, so over a period the mean
accelerations vanish: ``J_l <dw_l/dt> = <T> + T_l = 0`` and the mean shaft
torque carries the load.  With the dual-input describing function
(:func:`~backlash_df.describing.dual_input_describing_function`: ``N(A, w, b)``
and its DC term ``N0``) the cycle solves

    N0(A, w, b) = -T_l                      (DC balance, :func:`~backlash_df.describing.dc_bias`)
    1 + G(jw) N(A, w, b) = 0                (first harmonic, as without load)

:func:`~backlash_df.limit_cycles.predict_limit_cycles` solves it whenever the rig
has a load torque; :func:`predict_loaded` is that call at a given load.  Treating
the bias as following A and w at once is the usual quasi-static assumption: the
integrator moves it slowly, over many periods.

A large enough load keeps the gear on one flank: the biased oscillation no
longer leaves contact, the loop is linear and (if stable) the cycle is gone.
:func:`load_limit` finds the load at which the DF's stable cycle disappears.
The amplitude search reaches below the half gap alpha: with a bias, a cycle
that only lifts off one flank can be smaller than alpha.
"""

import dataclasses

from ._json import json_ready
from .limit_cycles import LimitCyclePrediction, predict_limit_cycles
from .models import BacklashModel
from .simulation import simulated_limit_cycle

__all__ = ["predict_loaded", "LoadLimit", "load_limit"]


def predict_loaded(rig, model=None, load_torque=None, linear=None, amplitude_range=None, omega_range=None,
                   grid=(60, 80), near_miss_cutoff=0.5):
    """Biased limit cycles of a rig's loop under a constant load torque (module docs).

    :func:`~backlash_df.limit_cycles.predict_limit_cycles` with the DC balance at
    ``load_torque`` (also at zero load, with the amplitude search below alpha).

    Parameters
    ----------
    rig : Rig
    model : str or BacklashModel, optional
        Torque law (default the rig's).
    load_torque : float, optional
        T_l, N m (default ``rig.load.torque``).
    linear : DriveLoop, control.LTI or callable, optional
        The linear part (default the rig's PI loop).
    amplitude_range, omega_range : (float, float), optional
        Search box, rad and rad/s (default A from alpha / 50 to 200 alpha,
        w as :func:`~backlash_df.limit_cycles.default_ranges`).
    grid : (int, int)
        Scan points in A and w.
    near_miss_cutoff : float
        Largest ``|1 + G N|`` reported as a near miss.

    Returns
    -------
    LimitCyclePrediction
        Its cycles carry ``bias`` (rad), the mean of theta_d.
    """
    load_torque = rig.load.torque if load_torque is None else float(load_torque)
    return predict_limit_cycles(rig, model, linear=linear, amplitude_range=amplitude_range, omega_range=omega_range,
                                grid=grid, near_miss_cutoff=near_miss_cutoff, load_torque=load_torque)


@dataclasses.dataclass(frozen=True)
class LoadLimit:
    """The load torque above which the DF predicts no stable cycle, and where simulation loses it.

    Attributes
    ----------
    model : str
    torque : float
        T_l* (N m, signed as the load): the DF predicts a stable cycle below
        it and none above (to ``rtol``).
    below : LimitCyclePrediction
        The prediction at the largest load that still has the cycle.
    simulated : float or None
        The same limit in closed-loop simulation (started on the biased DF
        cycle at each load), N m; ``None`` if not simulated.
    """

    model: str
    torque: float
    below: LimitCyclePrediction
    simulated: float | None = None

    def to_dict(self):
        """JSON-ready: the limit and the simulated one (N m, null if not simulated), the last cycling prediction."""
        return json_ready({"model": self.model, "torque": self.torque, "simulated": self.simulated,
                           "below": self.below.to_dict()})

    def __repr__(self):
        cycle = self.below.stable_cycles[-1]
        sim = "" if self.simulated is None else f", simulation: {self.simulated:.4g} N m"
        return (f"LoadLimit({self.model}: DF cycle gone above T_l = {self.torque:.4g} N m{sim}; "
                f"last DF cycle A={cycle.amplitude:.4g} rad, bias={cycle.bias:.4g} rad)")


def _bisect(has_cycle, lo, hi, rtol):
    """Largest load with a cycle, by bisection of [lo, hi] (``has_cycle(lo)`` true, ``has_cycle(hi)`` false)."""
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if has_cycle(mid) else (lo, mid)
    return lo, hi


def load_limit(rig, model=None, upper=None, sign=1.0, rtol=0.01, grid=(20, 30), simulate=False, t_end=10.0,
               max_t_end=40.0):
    """Find the load torque at which the stable limit cycle disappears.

    The DF limit is bisected between no load (where the loop must cycle) and
    ``upper`` (where it must not); assumes one transition in between.

    Parameters
    ----------
    rig : Rig
    model : str or BacklashModel, optional
    upper : float, optional
        Largest load considered, N m (default ``2 k alpha``).
    sign : {1.0, -1.0}
        Direction of the load.
    rtol : float
        Relative width of the final bracket.
    grid : (int, int)
        Scan grid of every prediction.
    simulate : bool
        Also bisect the load at which the closed-loop simulation loses the cycle.
    t_end, max_t_end : float
        Simulated times, s.

    Returns
    -------
    LoadLimit or None
        ``None`` when the unloaded DF has no stable cycle or the cycle survives ``upper``.
    """
    if not isinstance(model, BacklashModel):
        model = rig.make_model(model)
    upper = 2.0 * model.stiffness * model.half_gap if upper is None else float(upper)
    found = {}

    def predicted(torque):
        found[torque] = predict_loaded(rig, model, sign * torque, grid=grid)
        return bool(found[torque].stable_cycles)

    if not predicted(0.0) or predicted(upper):
        return None
    lo, hi = _bisect(predicted, 0.0, upper, rtol)
    simulated = None
    if simulate:
        def cycles(torque):
            cycle = predict_loaded(rig, model, sign * torque, grid=grid).stable_cycles
            start = cycle[-1] if cycle else found[lo].stable_cycles[-1]
            measured, _ = simulated_limit_cycle(rig, model, t_end=t_end, max_t_end=max_t_end, load_torque=sign * torque,
                                                initial={"theta_d": start.bias}, kick=start.amplitude * start.omega)
            return measured.found

        simulated = sign * 0.5 * sum(_bisect(cycles, 0.0, hi, rtol)) if cycles(0.0) and not cycles(hi) else None
    return LoadLimit(model.name, sign * 0.5 * (lo + hi), found[lo], simulated)
