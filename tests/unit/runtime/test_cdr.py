"""rrps_runtime.cdr: the recording taps' encoders give MCAP's bytes and rclpy's messages."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_runtime.cdr import cdr_encoder, joint_state_cdr, pose_stamped_cdr, wrench_stamped_cdr

# ROS strings are C strings: no NUL inside
texts = st.text(st.characters(codec='utf-8', exclude_categories=['Cs'], exclude_characters='\x00'),
                max_size=20)
floats = st.floats(allow_nan=False, width=64)
stamps = st.tuples(st.integers(-2**31, 2**31 - 1), st.integers(0, 2**32 - 1))


def _reference(type_name):
    """MCAP's own ros2 encoder of ``type_name`` (a dict of fields -> CDR bytes)."""
    from mcap_ros2._dynamic import serialize_dynamic

    from rrps_recording.storage.schemas import message_schema
    return serialize_dynamic(type_name, message_schema(type_name))[type_name]


def _header(stamp, frame_id):
    return {'stamp': {'sec': stamp[0], 'nanosec': stamp[1]}, 'frame_id': frame_id}


@settings(max_examples=200, deadline=None)
@given(stamp=stamps, frame_id=texts, names=st.lists(texts, max_size=8),
       position=st.lists(floats, max_size=8), velocity=st.lists(floats, max_size=8),
       effort=st.lists(floats, max_size=8))
def test_joint_state(stamp, frame_id, names, position, velocity, effort):
    from builtin_interfaces.msg import Time
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState
    msg = JointState(name=names, position=position, velocity=velocity, effort=effort)
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    msg.header.frame_id = frame_id
    data = joint_state_cdr(msg)
    assert data == _reference('sensor_msgs/msg/JointState')(
        {'header': _header(stamp, frame_id), 'name': names, 'position': position,
         'velocity': velocity, 'effort': effort})
    assert deserialize_message(data, JointState) == msg


def _pose_fields(msg, values):
    p, q = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z, q.x, q.y, q.z, q.w = values
    return {'pose': {'position': dict(zip('xyz', values[:3])),
                     'orientation': dict(zip('xyzw', values[3:]))}}


def _wrench_fields(msg, values):
    f, t = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z, t.x, t.y, t.z = values
    return {'wrench': {'force': dict(zip('xyz', values[:3])), 'torque': dict(zip('xyz', values[3:]))}}


# (type name, encoder, float64 field count, set the fields and give them as a dict)
STAMPED = [('geometry_msgs/msg/PoseStamped', pose_stamped_cdr, 7, _pose_fields),
           ('geometry_msgs/msg/WrenchStamped', wrench_stamped_cdr, 6, _wrench_fields)]


@pytest.mark.parametrize(('type_name', 'encode', 'size', 'fill'), STAMPED,
                         ids=[kind[0].rsplit('/', 1)[1] for kind in STAMPED])
@settings(max_examples=100, deadline=None)
@given(stamp=stamps, frame_id=texts, values=st.lists(floats, min_size=7, max_size=7))
def test_stamped_float_fields(type_name, encode, size, fill, stamp, frame_id, values):
    from builtin_interfaces.msg import Time
    from rclpy.serialization import deserialize_message

    from rrps_recording.storage.schemas import message_class
    msg_type = message_class(type_name)
    msg = msg_type()
    msg.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    msg.header.frame_id = frame_id
    fields = fill(msg, values[:size])
    data = encode(msg)
    assert data == _reference(type_name)({'header': _header(stamp, frame_id), **fields})
    assert deserialize_message(data, msg_type) == msg


def test_a_message_that_changes_names_and_frames_every_time_is_encoded_right():
    """The cached fixed parts (frame, joint names) never leak from one message to the next,
    also past the cache's limit."""
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState
    for i in range(300):
        msg = JointState(name=[f'joint_{i}', 'b' * (i % 7)], position=[float(i)] * (i % 3))
        msg.header.frame_id = 'f' * (i % 11)
        assert deserialize_message(joint_state_cdr(msg), JointState) == msg


@pytest.mark.parametrize(('type_name', 'known'), [
    ('sensor_msgs/msg/JointState', True), ('geometry_msgs/msg/PoseStamped', True),
    ('geometry_msgs/msg/WrenchStamped', True), ('visualization_msgs/msg/MarkerArray', False)])
def test_encoders_are_found_by_type_name(type_name, known):
    assert (cdr_encoder(type_name) is not None) == known
