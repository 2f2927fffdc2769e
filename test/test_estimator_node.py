"""``downhole_estimator`` over DDS beside ``twin_node``: fed only the twin's surface
topics, its estimate of the bit follows the twin's own bit topics."""
import math
import time

import numpy as np
import pytest

rclpy = pytest.importorskip('rclpy')
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from geometry_msgs.msg import TwistStamped, TwistWithCovarianceStamped, WrenchStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from drill_twin.ros.estimator_node import EstimatorNode  # noqa: E402
from drill_twin.ros.twin_node import TwinNode  # noqa: E402
from drill_twin.topics import SURFACE_INPUTS  # noqa: E402


def _stamped(extract):
    return lambda m: (time.monotonic(), extract(m))


def test_estimator_node_follows_the_twin_from_surface_topics_only(rig):
    twin = rig.add(TwinNode(context=rig.ctx, parameter_overrides=[
        Parameter('real_time_factor', value=1.0), Parameter('stability_period_s', value=0.0)]))
    est = rig.add(EstimatorNode(context=rig.ctx, parameter_overrides=[
        Parameter('self_tuning_period_s', value=0.0)]))
    # what the estimator listens to: the surface topics and nothing else
    subscribed = {name.lstrip('/') for name, _ in
                  est.get_subscriber_names_and_types_by_node('downhole_estimator', '/')}
    assert subscribed - {'parameter_events'} == set(SURFACE_INPUTS)
    rig.listen('bit/velocity', TwistStamped,
               _stamped(lambda m: (m.twist.angular.x, m.twist.linear.x)))
    rig.listen('bit/wrench', WrenchStamped,
               _stamped(lambda m: (m.wrench.torque.x, m.wrench.force.x)))
    rig.listen('estimate/bit/velocity', TwistWithCovarianceStamped,
               _stamped(lambda m: (m.twist.twist.angular.x, m.twist.covariance[21],
                                   m.twist.twist.linear.x, m.twist.covariance[0])))
    rig.listen('estimate/bit/wrench', WrenchStamped,
               _stamped(lambda m: (m.wrench.torque.x, m.wrench.force.x)))
    rig.listen('/diagnostics', DiagnosticArray, lambda m: [
        (s.name, s.level, {kv.key: kv.value for kv in s.values}, s.message)
        for s in m.status])
    assert rig.spin_until(lambda: len(rig.data['estimate/bit/velocity']) > 1000, 60)
    assert twin.twin.time_s > 8.0
    truth = np.array([(t, *v) for t, v in rig.data['bit/velocity']])
    estimate = np.array([(t, *v) for t, v in rig.data['estimate/bit/velocity']])
    late = estimate[estimate[:, 0] > estimate[0, 0] + 3.0]     # after the filter settled
    nearest = np.interp(late[:, 0], truth[:, 0], truth[:, 1])
    mean_speed = truth[:, 1].mean()
    assert mean_speed == pytest.approx(12.57, rel=0.05)
    # truth and estimate are matched by arrival time (up to a tick apart): 10 % of the mean
    assert np.sqrt(np.mean((late[:, 1] - nearest) ** 2)) < 0.1 * mean_speed
    assert np.all(late[:, 2] > 0)                              # a variance is published
    # the bit's axial speed [m/s] with its variance: the error is as large as it says
    axial_error = late[:, 3] - np.interp(late[:, 0], truth[:, 0], truth[:, 2])
    axial_std = np.sqrt(late[:, 4].mean())
    assert np.all(late[:, 4] > 0)
    assert np.sqrt(np.mean(axial_error ** 2)) < 3 * axial_std
    true_wrench = np.array([w for _, w in rig.data['bit/wrench']])
    est_wrench = np.array([w for _, w in rig.data['estimate/bit/wrench']][-300:])
    assert est_wrench[:, 0].mean() == pytest.approx(true_wrench[:, 0].mean(), rel=0.1)
    assert est_wrench[:, 1].mean() == pytest.approx(true_wrench[:, 1].mean(), rel=0.1)
    mine = [s for arr in rig.data['/diagnostics'] for s in arr
            if s[0] == 'drill_twin: downhole_estimator']
    assert mine and 'nis_torsional' in mine[-1][2]

    # corrupt surface torque samples: refused (counted, diagnostics warn), the estimate
    # goes on from the held value and still follows the truth
    # The estimator subscribes with the sensor-data QoS (best effort, keep last 5), as a
    # rig's sensor stream is: a sample may be dropped when the executor falls behind the
    # twin's own 50 Hz stream.  So each corrupt sample is sent until the estimator has
    # counted it (diagnostics at 1 Hz), then the next.
    glitch = rig.publisher('surface/torque')
    start = len(rig.data['estimate/bit/velocity'])
    for value in (math.nan, math.inf, 1e30, -1e30):
        counted = _estimator_status(rig)[1]
        for _ in range(5):
            glitch.publish(Float64(data=value))
            if rig.spin_until(lambda c=counted: _estimator_status(rig)[1] > c, 3.0):
                break
        assert _estimator_status(rig)[1] == counted + 1, value
    level, refused, message = _estimator_status(rig)
    assert refused == 4 and level == 1 and 'surface/torque' in message
    assert rig.spin_until(lambda: len(rig.data['estimate/bit/velocity']) > start + 200, 20)
    truth = np.array([(t, *v) for t, v in rig.data['bit/velocity']])
    after = np.array([(t, *v) for t, v in rig.data['estimate/bit/velocity'][start:]])
    assert np.all(np.isfinite(after[:, 1]))
    nearest = np.interp(after[:, 0], truth[:, 0], truth[:, 1])
    assert np.sqrt(np.mean((after[:, 1] - nearest) ** 2)) < 0.1 * mean_speed


def _estimator_status(rig):
    """(level, refused samples, message) of the estimator's last diagnostics."""
    mine = [s for arr in rig.data['/diagnostics'] for s in arr
            if s[0] == 'drill_twin: downhole_estimator']
    if not mine:
        return 0, 0, ''
    _, level, values, message = mine[-1]
    level = level[0] if isinstance(level, bytes) else level
    return level, int(values.get('rejected_samples', 0)), message
