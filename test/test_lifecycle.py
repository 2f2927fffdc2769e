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

from drill_twin.errors import ParameterError  # noqa: E402
from drill_twin.io.mcap_reader import open_recording  # noqa: E402
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


#: every transition id of lifecycle_msgs/Transition, and ids no state has
TRANSITION_IDS = sorted({v for k, v in vars(Transition).items()
                         if k.startswith('TRANSITION_') and isinstance(v, int)} | {99, 254})


def _available(node):
    return {t[0] for t in node._state_machine.available_transitions}


def test_every_transition_request_in_every_state_gets_an_answer(rig):
    """A transition that does not start from the current state (``ros2 lifecycle set
    /drill_twin configure`` while active, a mistyped id) is answered ``success: false`` and
    changes nothing; before, the request raised inside rclpy's service callback and the
    process died.  Every id of lifecycle_msgs/Transition (and some no state has) in each of
    the three primary states; the twin publishes again once active."""
    node = managed_twin(rig)
    rig.listen('surface/torque', Float64, lambda m: m.data)
    path = {State.PRIMARY_STATE_UNCONFIGURED: [],
            State.PRIMARY_STATE_INACTIVE: [Transition.TRANSITION_CONFIGURE],
            State.PRIMARY_STATE_ACTIVE: [Transition.TRANSITION_ACTIVATE]}
    refused = 0
    for goal, steps in path.items():
        for step in steps:
            assert transition(rig, step)
        assert state(rig) == goal
        for transition_id in TRANSITION_IDS:
            if transition_id in _available(node):
                continue                     # a valid transition: tested above
            assert not transition(rig, transition_id), transition_id
            assert state(rig) == goal
            refused += 1
        # by label, as ros2 lifecycle set sends it
        request = ChangeState.Request(transition=Transition(label='configure'))
        if goal != State.PRIMARY_STATE_UNCONFIGURED:
            assert not rig.call(ChangeState, '/drill_twin/change_state', request, 30).success
            assert state(rig) == goal
    assert refused > 3 * 20
    heard = len(rig.data['surface/torque'])
    assert rig.spin_until(lambda: len(rig.data['surface/torque']) > heard + 10, 30)


def test_use_sim_time_is_refused_by_the_twin_that_makes_the_clock(rig):
    """With use_sim_time the twin's timers would wait for a /clock that only the twin
    publishes: it fell silent for good without a word.  Refused at run time (the old value
    kept) and at start-up (one line)."""
    node = rig.twin()
    res = node.set_parameters([Parameter('use_sim_time', value=True)])[0]
    assert not res.successful and 'clock' in res.reason
    heard = node.twin.time_s
    assert rig.spin_until(lambda: node.twin.time_s > heard + 0.5, 30)
    with pytest.raises(ParameterError, match='use_sim_time'):
        TwinNode(context=rig.ctx, parameter_overrides=[
            Parameter('use_sim_time', value=True), Parameter('stability_period_s', value=0.0)])


def test_a_configure_that_fails_late_logs_why_and_a_retry_records_to_a_new_file(rig,
                                                                              tmp_path):
    """A scenario whose steps need a hoist, on a string without one: the configure fails
    with its reason (before: a TypeError at start-up, nothing logged when managed), the
    node stays unconfigured and alive, and a second attempt does not overwrite the first
    attempt's file."""
    scenario = tmp_path / 'hoist.yaml'
    scenario.write_text('description: needs a block\nconfiguration: benchmark_fem\n'
                        'start: drilling\nsteps:\n  - pick_up: {above_bottom_m: 1.0}\n')
    record = tmp_path / 'run.mcap'
    node = managed_twin(rig, scenario=str(scenario), record_path=str(record))
    assert not transition(rig, Transition.TRANSITION_CONFIGURE)
    assert state(rig) == State.PRIMARY_STATE_UNCONFIGURED and node.twin is None
    assert not transition(rig, Transition.TRANSITION_CONFIGURE)
    made = sorted(p.name for p in tmp_path.glob('*.mcap'))
    assert len(made) == len(set(made))
    with pytest.raises(ParameterError):
        TwinNode(context=rig.ctx, parameter_overrides=[
            Parameter('scenario', value=str(scenario)),
            Parameter('stability_period_s', value=0.0)])
