"""Friction in the loop, end to end on records: each rig with its friction against the same rig without it.

Run: ``python benchmarks/bench_friction.py [--repeat N]`` (about 2 minutes on one core).

Every step is the command line a user types, run in a fresh interpreter on this
checkout (``python -c "from backlash_df.cli import main; main()" ...``), timed end to end:
wall time and the child's CPU time (``resource.getrusage(RUSAGE_CHILDREN)``), best of
``--repeat`` (each command is run once before, so that numba's cache is warm on both sides).

Cases:

a. **KUKA** (``examples/kuka/``): ``diagnose --rig-out`` on the axis-1 record; the written
   rig gets a cascade (:data:`KUKA_CONTROLLER`: the record's drive runs a position P loop
   around a speed P loop with a model feed-forward, which the rig format cannot state, so
   a P position / PI speed cascade of its own, tuned below the shaft mode); then
   ``simulate`` on a position ramp (:data:`KUKA_RAMP`), the drive's measured friction in
   the loop, against the same rig without its friction (the named alternative): the
   tracking error on the ramp, the error left at the end and the settling after the ramp.
b. **The project's generator** (:func:`backlash_df.identify.synthesize`): a record of
   ``examples/diagnose_rig.toml``'s drive with Coulomb, breakaway and viscous friction on
   the load side (no test signal, speed noise 0.002 rad/s, no data-sheet error, 2 s),
   ``simulate --compare`` with the true rig (its ``[friction]`` the generator's, law
   ``exact`` as the generator's), and with the friction removed.
c. **EMPS** (``examples/emps/``): ``diagnose --rig-out`` on the record, then ``simulate
   --inputs emps_reference.csv --compare emps_record.csv`` with the written rig, with its
   friction removed, and with the data set's own values (IDIM-LS: M = 95.11 kg, F_v = 203.5
   N s/m, F_c = 20.39 N; no offset: the loop does not model one); then, as for KUKA,
   ``predict`` and ``tune --vary kv`` of the written rig (its cascade and torque limit the
   data set's) with its friction and without.

**Accuracy**: the fit of each column against the record (``fit_percent``, 100 (1 - |y -
y_sim| / |y - mean y|) %); for a, the response against the reference (no record).
"""

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from backlash_df import load_rig, rig_from_dict, write_rig  # noqa: E402
from backlash_df.identify import Experiment, synthesize, write_measurements  # noqa: E402
from backlash_df.identify.effects import STRIBECK_SPEED  # noqa: E402

CLI = "import sys; from backlash_df.cli import main; sys.exit(main())"
KUKA, EMPS = ROOT / "examples" / "kuka", ROOT / "examples" / "emps"

#: The KUKA axis's cascade (load side).  The rigid body J = J_m + J_l = 1530 kg m^2 (the rig's);
#: the shaft mode sqrt(k (1/J_m + 1/J_l)) = 112 rad/s.  Speed PI on the motor: crossover kp / J = 25
#: rad/s, 4.5 times under the shaft mode; its integral corner 1 / ti = 6.25 rad/s, 4 times under the
#: crossover.  Position P on the motor angle (the drive's own encoder): kv = 6 1/s, 4 times under the
#: speed loop.  The limit is the record's largest torque (2355 N m at the link) with 25 % to spare.
KUKA_CONTROLLER = {"structure": "cascade", "feedback": "motor", "position_feedback": "motor", "kp": 38250.0,
                   "ti": 0.16, "kv": 6.0, "torque_limit": 3000.0}
#: The position reference: 0 to 0.4 rad in 1.5 s (0.27 rad/s, the record's speeds are up to 0.44 rad/s), then held
#: until 4 s; every 1 ms.
KUKA_RAMP = (0.4, 1.5, 4.0, 1e-3)
KUKA_BAND = 1e-4  # rad: the settling band after the ramp (0.006 degrees; the record's encoder steps are 2e-6 rad)

#: The generator's record: the hidden friction (load side) and its excitation.
GENERATED_FRICTION = {"coulomb_load": 4.0, "breakaway_load": 6.0, "viscous_load": 1.0}
GENERATED = Experiment(test_amplitude=0.0, noise=0.002, warmup=0.0)
GENERATED_SEED, GENERATED_DURATION = 3, 2.0

#: The EMPS data set's own reference model (examples/emps/README.md): mass, viscous and Coulomb friction.
EMPS_DATASET = {"mass": 95.11, "viscous_load": 203.5, "coulomb_load": 20.39}


def cli(*args, repeat=1):
    """(best wall s, its CPU s, stdout) of the command line ``args`` in a fresh interpreter on this checkout."""
    best = None
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", CLI, *map(str, args)], cwd=ROOT, capture_output=True, text=True,
                              env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "OPENBLAS_NUM_THREADS": "1"})
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(map(str, args))}: exit {done.returncode}: {done.stderr.strip()}")
        cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
        if best is None or wall < best[0]:
            best = (wall, cpu, done.stdout)
    return best


def variant(rig, path, *, friction=None, controller=None, model=None, plant=None):
    """Write ``rig`` with its ``[friction]`` replaced (``{}``: none), a ``[controller]``, a law or plant values
    to ``path`` (the ``[uncertainty]`` boxes dropped: they need not hold the changed values); returns ``path``."""
    data = rig.to_dict()
    data.pop("uncertainty", None)
    if friction is not None:
        data["friction"] = friction
    if controller is not None:
        data["controller"] = controller
    if model is not None:
        data["model"] = {"backlash": model}
    data["plant"].update(plant or {})
    write_rig(rig_from_dict(data, source=str(path)), path)
    return path


def simulate(rig_path, folder, inputs, compare=None, repeat=1):
    """(wall s, CPU s, the ``--json`` run) of ``simulate`` on ``rig_path``."""
    out = Path(folder) / f"{Path(rig_path).stem}.json"
    args = ["simulate", rig_path, "--inputs", inputs, "--json", out] + (["--compare", compare] if compare else [])
    cli(*args)  # warms numba's cache
    wall, cpu, _ = cli(*args, repeat=repeat)
    return wall, cpu, json.loads(out.read_text())


def diagnose(record, rig_path, out, repeat=1):
    """(wall s, CPU s) of ``diagnose --rig-out``, and the rig written."""
    wall, cpu, _ = cli("diagnose", record, "--rig", rig_path, "--rig-out", out, repeat=repeat)
    return wall, cpu, load_rig(out)


def row(case, name, wall, cpu, figures):
    print(f"  {case:<10}{name:<48}{wall:8.2f}{cpu:8.2f}  {figures}", flush=True)


def fits_text(run):
    return ", ".join(f"{column} {value:.2f}" for column, value in run["fit_percent"].items())


# --------------------------------------------------------------------------- a. KUKA


def ramp_response(run):
    """(largest |error| on the ramp, |error| at the end, settling time after the ramp, the position, the motor
    torque) of a KUKA run: rad, s, rad (load side), N m (load side)."""
    height, ramp, _, _ = KUKA_RAMP
    columns = run["columns"]
    time_ = np.asarray(columns["time"])
    angle = np.asarray(columns["motor_angle"]) / run["gear_ratio"]  # position feedback: the motor angle, load side
    reference = height * np.minimum(time_ / ramp, 1.0)
    error = reference - angle
    outside = np.flatnonzero(np.abs(error) > KUKA_BAND)
    settled = time_[outside[-1] + 1] - ramp if outside.size and outside[-1] + 1 < time_.size else np.nan
    torque = np.asarray(columns["motor_torque"]) * run["gear_ratio"]
    return np.abs(error[time_ <= ramp]).max(), abs(error[-1]), settled, angle, torque


def kuka_case(folder, repeat):
    height, ramp, t_end, step = KUKA_RAMP
    wall, cpu, diagnosed = diagnose(KUKA / "kuka_axis1.csv", KUKA / "kuka_rig.toml", folder / "kuka_diagnosed.toml",
                                    repeat)
    friction = diagnosed.friction
    row("KUKA", "diagnose --rig-out", wall, cpu, f"coulomb_load {friction.coulomb_load:.1f} N m, viscous_load "
        f"{friction.viscous_load:.0f} N m s/rad")
    time_ = np.arange(round(t_end / step) + 1) * step
    inputs = folder / "kuka_ramp.csv"
    np.savetxt(inputs, np.column_stack([time_, height * np.minimum(time_ / ramp, 1.0)]), delimiter=",",
               header="time,reference", comments="", fmt="%.9g")
    results = {}
    for name, changes in (("with its friction", {}), ("without friction", {"friction": {}})):
        path = variant(diagnosed, folder / f"kuka_cascade_{'bare' if changes else 'friction'}.toml",
                       controller=KUKA_CONTROLLER, **changes)
        wall, cpu, run = simulate(path, folder, inputs, repeat=repeat)
        peak, final, settled, _, _ = results[name] = ramp_response(run)
        row("KUKA", f"simulate, {name}", wall, cpu, f"ramp error {peak * 1e3:.2f} mrad, end error {final * 1e6:.2f} "
            f"urad, settled in {KUKA_BAND * 1e3:g} mrad {settled:.3f} s after the ramp ({run['steps']} steps, "
            f"{run['events']} events)")
        results[name] += (cpu,)
    (peak_f, final_f, settle_f, angle_f, torque_f, cpu_f), (peak_b, final_b, settle_b, angle_b, torque_b, cpu_b) = \
        results.values()
    on_ramp = slice(round(0.5 * ramp / step), round(ramp / step))  # the ramp's second half: the loop at speed
    print(f"  KUKA: friction / none: ramp error {peak_f / peak_b:.2f}x, settling {settle_f / settle_b:.2f}x, "
          f"end error {final_f * 1e6:.2f} against {final_b * 1e6:.2f} urad; the positions differ by at most "
          f"{np.abs(angle_f - angle_b).max() * 1e3:.3f} mrad, the torques on the ramp's second half by "
          f"{np.mean(torque_f[on_ramp] - torque_b[on_ramp]):.0f} N m on average (the friction at "
          f"{height / ramp:.3g} rad/s: {friction.coulomb_load + friction.viscous_load * height / ramp:.0f} N m); "
          f"simulate's CPU time {cpu_f / cpu_b:.2f}x")
    kuka_design(folder, diagnosed, repeat)


def kuka_design(folder, diagnosed, repeat):
    """``predict`` and ``tune --vary kv`` of the KUKA cascade, its torque limit in it, with the diagnosed friction and
    without: the verdict, the tuning and their time (the friction's describing function solved together with the
    saturation's)."""
    design(folder, "KUKA", diagnosed, KUKA_CONTROLLER, "1,60", repeat)


def design(folder, case, diagnosed, controller, kv_range, repeat):
    """The rows of ``predict`` and ``tune --vary kv`` of ``diagnosed`` with ``controller``, with its friction and
    without (the nominal rig: ``--nominal``; gain margin 1)."""
    for name, changes in (("with its friction", {}), ("without friction", {"friction": {}})):
        tag = f"{case.lower()}_{'bare' if changes else 'friction'}"
        path = variant(diagnosed, folder / f"design_{tag}.toml", controller=controller, **changes)
        wall, cpu, text = cli("predict", path, repeat=repeat)
        verdict = next(line for line in text.splitlines() if line.startswith("phase-plane:")).split(":", 1)[1]
        row(case, f"predict, {name}", wall, cpu, verdict.strip()[:150])
        wall, cpu, text = cli("tune", path, "--vary", "kv", kv_range, "--gain-margin", "1", "--nominal", "--json",
                              folder / f"tune_{tag}.json", repeat=repeat)
        answer = json.loads((folder / f"tune_{tag}.json").read_text())
        row(case, f"tune --vary kv {kv_range}, {name}", wall, cpu,
            f"{'certified' if answer['feasible'] else 'none certified'}: kv = {answer['best']['values']['kv']:.4g} "
            f"1/s, bandwidth {answer['best']['bandwidth']:.4g} rad/s, {len(answer['searched']['certified'])} certificates")


# --------------------------------------------------------------------------- b. the generator's record


def generated_case(folder, repeat):
    base = load_rig(ROOT / "examples" / "diagnose_rig.toml")
    stribeck = STRIBECK_SPEED * GENERATED.speed_amplitude  # the generator's Stribeck speed
    hidden = {"coulomb_friction@load": GENERATED_FRICTION["coulomb_load"],
              "breakaway_friction@load": GENERATED_FRICTION["breakaway_load"],
              "viscous_friction@load": GENERATED_FRICTION["viscous_load"]}
    record = synthesize(base, hidden, seed=GENERATED_SEED, duration=GENERATED_DURATION, experiment=GENERATED,
                        datasheet_error=0.0, encoder_counts=2 ** 24).measurements
    write_measurements(folder / "generated_record.csv", record, precision=12)
    reference = GENERATED.speed_amplitude * np.sin(2 * np.pi * GENERATED.speed_frequency * record.time)
    np.savetxt(folder / "generated_inputs.csv", np.column_stack([record.time, reference, record.load_torque]),
               delimiter=",", header="time,reference,load_torque", comments="", fmt="%.12g")
    fits = {}
    for name, friction in (("true rig (its friction)", dict(GENERATED_FRICTION, stribeck_speed=stribeck)),
                           ("friction removed", {})):
        path = variant(base, folder / f"generated_{'bare' if not friction else 'true'}.toml", friction=friction,
                       model="exact")
        wall, cpu, run = simulate(path, folder, folder / "generated_inputs.csv", folder / "generated_record.csv",
                                  repeat)
        fits[name] = run["fit_percent"]
        row("generator", f"simulate --compare, {name}", wall, cpu, fits_text(run))
    true, bare = fits.values()
    print(f"  generator: lowest fit {min(true.values()):.2f} % with the true rig, {min(bare.values()):.2f} % without "
          f"its friction; misfit (100 - fit) without / with, per column: "
          + ", ".join(f"{c} {(100 - bare[c]) / (100 - true[c]):.0f}x" for c in true))


# --------------------------------------------------------------------------- c. EMPS


def emps_case(folder, repeat):
    wall, cpu, diagnosed = diagnose(EMPS / "emps_record.csv", EMPS / "emps_rig.toml", folder / "emps_diagnosed.toml",
                                    repeat)
    friction = diagnosed.friction
    row("EMPS", "diagnose --rig-out", wall, cpu, f"coulomb_load {friction.coulomb_load:.2f} N, viscous_load "
        f"{friction.viscous_load:.1f} N s/m, mass {diagnosed.plant.motor_inertia + diagnosed.plant.load_inertia:.2f} kg"
        f", torque_offset {diagnosed.load.torque_offset:g} N")
    half = EMPS_DATASET["mass"] / 2
    variants = (("diagnosed rig", folder / "emps_diagnosed.toml"),
                ("diagnosed, friction removed", variant(diagnosed, folder / "emps_bare.toml", friction={})),
                ("data set's M, F_v, F_c", variant(diagnosed, folder / "emps_dataset.toml", friction={
                    "coulomb_load": EMPS_DATASET["coulomb_load"], "viscous_load": EMPS_DATASET["viscous_load"]},
                    plant={"motor_inertia": half, "load_inertia": half})))
    fits = {}
    for name, path in variants:
        wall, cpu, run = simulate(path, folder, EMPS / "emps_reference.csv", EMPS / "emps_record.csv", repeat)
        fits[name] = run["fit_percent"]
        row("EMPS", f"simulate --compare, {name}", wall, cpu, fits_text(run))
    with_, bare, dataset = (fits[name]["motor_torque"] for name, _ in variants)
    print(f"  EMPS: motor force fit {with_:.1f} % with the diagnosed friction, {bare:.1f} % without, {dataset:.1f} % "
          f"with the data set's; misfit without / with {(100 - bare) / (100 - with_):.1f}x")
    design(folder, "EMPS", diagnosed, diagnosed.to_dict()["controller"], "20,1000", repeat)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1, help="best of N runs of each command (default 1)")
    args = parser.parse_args()
    print(f"friction in the loop, end to end (command lines in fresh interpreters, best of {args.repeat}; wall and CPU "
          f"s of each)")
    print(f"  {'case':<10}{'step':<48}{'wall s':>8}{'CPU s':>8}  figures (fits in %)")
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        kuka_case(folder, args.repeat)
        generated_case(folder, args.repeat)
        emps_case(folder, args.repeat)


if __name__ == "__main__":
    main()
