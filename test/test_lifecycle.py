"""The twin as a managed (lifecycle) node, driven through the lifecycle service interface
(``~/change_state``, ``~/get_state``: what ``ros2 lifecycle set/get`` call) over DDS,
in-process; spin until a condition or a deadline."""
import pytest

rclpy = pytest.importorskip('rclpy')
from lifecycle_msgs.msg import State, Transition  # noqa: E402
from lifecycle_msgs.srv import ChangeState, GetState  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from drill_twin.io.mcap_reader import open_recording  # noqa: E402
from drill_twin.physics.parameters import ParameterError  # noqa: E402
from drill_twin.ros.twin_node import TwinNode  # noqa: E402


def managed_twin(rig, **params):
    return rig.twin(**{'autostart': False, **params})


def state(rig):
    return rig.call(GetState, '/drill_twin/get_state', GetState.Request(), 30).current_state.id


def transition(rig, transition_id):
    request = ChangeState.Request(transition=Transition(id=transition_id))
    return rig.call(ChangeState, '/drill_twin/change_state', request, 30).success


def test_lifecycle_transitions_through_the_service_interface(rig, tmp_path):
    record = tmp_path / 'run.mcap'
    node = managed_twin(rig, record_path=str(record))
    rig.listen('surface/torque', Float64, lambda m: m.data)
    assert state(rig) == State.PRIMARY_STATE_UNCONFIGURED and node.twin is None
    assert not rig.call(Trigger, '/drill_twin/reset', Trigger.Request(), 30).success

    assert transition(rig, Transition.TRANSITION_CONFIGURE)
    assert state(rig) == State.PRIMARY_STATE_INACTIVE
    assert node.twin is not None and record.exists()
    # inactive: the model is loaded but held, nothing measured is published
    assert not rig.spin_until(lambda: node.twin.time_s > 0.0 or rig.data['surface/torque'],
                              0.5)

    assert transition(rig, Transition.TRANSITION_ACTIVATE)
    assert state(rig) == State.PRIMARY_STATE_ACTIVE
    assert rig.spin_until(lambda: node.twin.time_s > 0.3 and rig.data['surface/torque'], 30)

    assert transition(rig, Transition.TRANSITION_DEACTIVATE)
    assert state(rig) == State.PRIMARY_STATE_INACTIVE
    held, heard = node.twin.time_s, len(rig.data['surface/torque'])
    assert not rig.spin_until(lambda: node.twin.time_s != held, 0.5)
    rig.spin_until(lambda: False, 0.1)   # what was in flight before the hold arrives
    heard = len(rig.data['surface/torque'])
    assert not rig.spin_until(lambda: len(rig.data['surface/torque']) > heard, 0.5)

    assert transition(rig, Transition.TRANSITION_ACTIVATE)  # from where it held
    assert rig.spin_until(lambda: node.twin.time_s > held, 30)
    assert node.twin.time_s < held + 0.5

    assert transition(rig, Transition.TRANSITION_DEACTIVATE)
    assert transition(rig, Transition.TRANSITION_CLEANUP)
    assert state(rig) == State.PRIMARY_STATE_UNCONFIGURED and node.twin is None
    first = open_recording(record)   # closed by cleanup: complete, no recovery needed
    assert first.message_counts['/surface/torque'] >= len(rig.data['surface/torque']) > 0

    # configure again: a new run, recorded beside the first, which stays as it was
    assert transition(rig, Transition.TRANSITION_CONFIGURE)
    assert node.twin.time_s == 0.0
    assert (tmp_path / 'run_2.mcap').exists()
    assert open_recording(record).message_counts == first.message_counts
    assert transition(rig, Transition.TRANSITION_INACTIVE_SHUTDOWN)
    assert state(rig) == State.PRIMARY_STATE_FINALIZED
    assert open_recording(tmp_path / 'run_2.mcap').message_counts.get('/surface/torque', 0) == 0


def test_a_failed_configure_leaves_the_node_unconfigured_and_alive(rig):
    node = managed_twin(rig, overrides=['string.blades=-1'])
    assert not transition(rig, Transition.TRANSITION_CONFIGURE)
    assert state(rig) == State.PRIMARY_STATE_UNCONFIGURED and node.twin is None
    assert not rig.call(Trigger, '/drill_twin/reset', Trigger.Request(), 30).success


def test_autostart_runs_at_once_and_a_bad_configuration_raises_one_error(rig):
    node = managed_twin(rig, autostart=True)
    assert state(rig) == State.PRIMARY_STATE_ACTIVE
    assert rig.spin_until(lambda: node.twin.time_s > 0.1, 30)
    with pytest.raises(ParameterError, match='blades'):
        TwinNode(context=rig.ctx, parameter_overrides=[
            Parameter('overrides', value=['string.blades=-1']),
            Parameter('stability_period_s', value=0.0)])
