"""A result holds what it was computed from: the law as an object, the rig, the user's linear part.

Later stages (verification, the verdict, the exact orbits) read them from the prediction and
never rebuild them from names: a law with a gap of its own gives that law's cycle at every
stage, a user's linear part is simulated without being passed again, and a later stage handed
another law, rig or linear part refuses in one line.

The independent reference is homogeneity: without a load torque, the loop is linear but for
the backlash, and the phase plane law (23) scales with the gap, T(l x, l v; l alpha) =
l T(x, v; alpha); so the loop with a law of gap 2 alpha cycles at exactly twice the amplitude
of the rig's own (gap alpha), at the same frequency, in the DF, the simulation and the orbit.
"""

import functools

import pytest

import backlash_df as bd
from backlash_df.loops import drive_loop
from conftest import example_rig


@pytest.fixture(scope="module")
def rig():
    return example_rig("load_feedback")  # alpha = 0.05 rad


@pytest.fixture(scope="module")
def wide_law(rig):
    """The phase plane law on the rig's shaft with twice its gap."""
    return bd.make_model("phase-plane", **{**rig.plant.shaft, "half_gap": 2.0 * rig.plant.half_gap})


@pytest.fixture(scope="module")
def own_cycle(rig):
    """The rig's own law's DF cycle, verified, and its exact orbit: the reference, scaled by 2."""
    prediction = bd.verify_limit_cycles(rig, bd.predict_limit_cycles(rig, "phase-plane"))
    orbit = bd.periodic_orbit(rig, "phase-plane", seed=prediction.cycles[0])
    return prediction.cycles[0], orbit


def test_a_law_with_its_own_gap_gives_its_cycle_at_every_stage(rig, wide_law, own_cycle):
    """predict -> verify -> judge -> orbit, no amplitude_range: the law's gap throughout."""
    reference, reference_orbit = own_cycle
    prediction = bd.predict_limit_cycles(rig, wide_law)
    assert prediction.law == wide_law and prediction.rig.plant.half_gap == wide_law.half_gap
    assert prediction.amplitude_range[0] > wide_law.half_gap  # the search box from the law's gap
    (cycle,) = prediction.cycles
    assert cycle.amplitude == pytest.approx(2.0 * reference.amplitude, rel=1e-7)  # homogeneity
    assert cycle.omega == pytest.approx(reference.omega, rel=1e-7)

    simulated = bd.verify_limit_cycles(rig, prediction).cycles[0].simulated
    verdict = bd.judge_loop(rig, prediction, exact=True)
    orbit = bd.periodic_orbit(rig, wide_law, seed=cycle)
    assert orbit.amplitude == pytest.approx(2.0 * reference_orbit.amplitude, rel=1e-6)
    assert orbit.omega == pytest.approx(reference_orbit.omega, rel=1e-6)
    assert simulated.amplitude == pytest.approx(orbit.amplitude, rel=0.01)
    assert verdict.verdict == "limit cycle"
    assert [o.amplitude for o in verdict.orbits] == pytest.approx([orbit.amplitude], rel=1e-6)


def test_a_users_linear_part_is_carried_to_verification_and_verdict(rig, wide_law, own_cycle):
    """The rig's loop handed in as a python-control transfer function, then not passed again."""
    _, reference_orbit = own_cycle
    system = drive_loop(rig).transfer_function()
    prediction = bd.predict_limit_cycles(rig, wide_law, linear=system)
    assert prediction.user_linear is system
    simulated = bd.verify_limit_cycles(rig, prediction).cycles[0].simulated
    assert simulated.amplitude == pytest.approx(2.0 * reference_orbit.amplitude, rel=0.01)
    assert bd.judge_loop(rig, prediction).verdict == "limit cycle"


def test_a_later_stage_refuses_another_law_rig_or_linear_part(rig, wide_law):
    system = drive_loop(rig).transfer_function()
    prediction = bd.predict_limit_cycles(rig, wide_law, linear=system, grid=(12, 16))
    with pytest.raises(ValueError, match="linear part given is not the one"):
        bd.verify_limit_cycles(rig, prediction, linear=drive_loop(rig).transfer_function())
    with pytest.raises(ValueError, match=r"rig given \(.*motor_feedback.toml\) is not the one"):
        bd.judge_loop(example_rig("motor_feedback"), prediction)
    with pytest.raises(ValueError, match="shooting takes the rig's own loop"):
        bd.exact_orbits(rig, prediction)


def test_a_users_describing_function_is_labelled_and_never_simulated_as_another_law(rig):
    """A DF handed in: the label says so; verification simulates the named law, or refuses."""
    carrier = functools.partial(bd.describing_function, bd.make_model("damped-dead-zone", **rig.plant.shaft))
    unnamed = bd.predict_limit_cycles(rig, describing=carrier, grid=(24, 32))
    assert unnamed.model == "user DF" and unnamed.law is None
    assert unnamed.to_dict()["model"] == "user DF"
    with pytest.raises(ValueError, match="no torque law named: pass model="):
        bd.verify_limit_cycles(rig, unnamed)
    named = bd.predict_limit_cycles(rig, "damped-dead-zone", describing=carrier, grid=(24, 32))
    assert named.model == "damped-dead-zone (user DF)"
    assert named.cycles[0].amplitude == pytest.approx(unnamed.cycles[0].amplitude, rel=1e-12)
    simulated = bd.verify_limit_cycles(rig, named).cycles[0].simulated
    own = bd.verify_limit_cycles(rig, bd.predict_limit_cycles(rig, "damped-dead-zone", grid=(24, 32)))
    assert simulated.amplitude == pytest.approx(own.cycles[0].simulated.amplitude, rel=1e-9)  # the named law's run


def test_rig_with_law_takes_the_laws_shaft(rig, wide_law):
    assert rig.with_law(rig.make_model()) is rig
    moved = rig.with_law(wide_law)
    assert moved.plant.shaft == wide_law.plant_params and moved.model == "phase-plane"
    assert moved.plant.motor_inertia == rig.plant.motor_inertia and moved.controller == rig.controller
