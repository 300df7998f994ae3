"""The launch-free harness itself: a message crosses two in-process nodes, and Ctrl-C-safe spin stops."""

from std_msgs.msg import String

from rrps_testing.ros_harness import Probe, Spinner, wait_for


def test_probe_round_trip(ros_context):
    sender = Probe(context=ros_context, name='sender')
    receiver = Probe(context=ros_context, name='receiver')
    got = receiver.collect(String, 'chatter')
    pub = sender.publisher(String, 'chatter')
    with Spinner(ros_context, [sender, receiver]):
        assert wait_for(lambda: receiver.count_publishers('chatter') == 1)
        assert wait_for(lambda: (pub.publish(String(data='hello')), got)[1])
    assert got[0].data == 'hello'
