"""MuJoCo's RK4 step without its bias-force pass (rail_mj.simulation.unbiased): the same bits as
mujoco.rollout, for the models it applies to, and only those."""

import mujoco
import numpy as np
import pytest
from conftest import MODELS
from mujoco import rollout

from rail_mj.layout import load_layout
from rail_mj.simulation import native, unbiased
from rail_mj.simulation.run import Request
from rail_mj.simulation.runner import prepare
from rail_mj.simulation.stepping import Pack, Running, stepping
from rail_mj.vehicle.spec import Vehicle

COACH = MODELS / "manchester-coach" / "manchester-coach.toml"


def test_packed_coaches_step_to_mujocos_bits():
    """Four coaches at 20-100 m/s in one model, 1500 steps from their 2 mm start with the native
    creep callback: every state and sensor value equal to mujoco.rollout's, bit for bit (the
    stepper leaves out only what is zero here: a tolerance would hide a stage left out wrongly)."""
    layout = load_layout(COACH)
    runs = [Running(k, prepare(Request(layout, v, 1000.0, 0.002))) for k, v in enumerate((20.0, 45.0, 70.0, 100.0))]
    pack = Pack(runs)
    model = pack.model
    assert pack.unbiased and unbiased.library() is not None
    n = 1500
    theirs, their_sensors = np.empty((1, n, pack.state.size)), np.empty((1, n, model.nsensordata))
    ours, our_sensors = np.empty((n, pack.state.size)), np.empty((n, model.nsensordata))
    with native.installed(), stepping():
        rollout.Rollout(nthread=0).rollout(
            [model], [mujoco.MjData(model)], pack.state[None], skip_checks=True, nstep=n, state=theirs,
            sensordata=their_sensors,
        )  # fmt: skip
        assert unbiased.roll(model, mujoco.MjData(model), pack.state, n, ours, our_sensors)
    assert np.abs(ours[-1, 1 : 1 + model.nq]).max() > 1e-4  # moving: the coaches' states differ from the start
    np.testing.assert_array_equal(ours, theirs[0])
    np.testing.assert_array_equal(our_sensors, their_sensors[0])


def test_a_nested_or_spatial_vehicle_is_stepped_by_mujoco():
    """The nested planar coach (car body -> bogie -> wheelset) has Coriolis forces in its joints,
    and the spatial coach gravity along its slides: neither qualifies (the flat twin, packed, does:
    the test above)."""
    coach = Vehicle(load_layout(COACH))
    assert not unbiased.applies(coach.model)
    spatial = Vehicle(load_layout(MODELS / "manchester-coach-spatial" / "manchester-coach-spatial.toml"))
    assert not unbiased.applies(spatial.stepped.model)


@pytest.mark.parametrize(
    "joints, qualifies, biased",
    [
        ('<joint type="slide" axis="0 1 0"/><joint type="hinge" axis="0 0 1"/>', True, False),
        ('<joint type="hinge" axis="0 0 1"/><joint type="slide" axis="0 1 0"/>', False, True),  # the slide turns
        ('<joint type="slide" axis="0 0 1"/>', False, True),  # along gravity
        ('<joint type="slide" axis="0 1 0"/><joint type="hinge" axis="0 0 1" pos="0.1 0 0"/>', False, True),
        # Not a principal axis: omega x I omega is perpendicular to the one hinge, so no bias here,
        # but refused: `applies` asks for what makes it zero in every model, not for what happens to.
        ('<joint type="slide" axis="0 1 0"/><joint type="hinge" axis="0 1 1"/>', False, False),
    ],
)
def test_applies_only_without_bias_forces(joints, qualifies, biased):
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><option integrator="RK4"><flag constraint="disable"/></option><worldbody><body>'
        f'{joints}<inertial pos="0 0 0" mass="2" diaginertia="1 2 3"/></body></worldbody></mujoco>'
    )
    assert unbiased.applies(model) is qualifies
    data = mujoco.MjData(model)
    data.qpos[:] = 0.3
    data.qvel[:] = 2.0
    mujoco.mj_forward(model, data)
    assert bool(np.abs(data.qfrc_bias).max() > 1e-6) is biased
