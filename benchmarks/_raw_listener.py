"""The recorder benchmark's bare baseline: receive every topic the recorder would, do nothing.

Subscribes raw (CDR bytes, never deserialised), in an EventsExecutor like the recorder, to every
topic under the namespace and /diagnostics that has a publisher, with the QoS the recorder would
request; re-checks the graph every second. Its CPU is what any Python process pays to receive
the stream, before a byte is written.

    python benchmarks/_raw_listener.py [--namespace /rrps]
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--namespace', default='/rrps')
    args = parser.parse_args()

    from rclpy.node import Node

    from rrps_interfaces.status import DIAGNOSTICS
    from rrps_recording.storage.qos import request_for_offers
    from rrps_recording.storage.schemas import message_class
    from rrps_recording.topic_graph import qos_spec, subscription_qos
    from rrps_runtime.process import run_nodes

    class RawListener(Node):
        """Raw subscriptions to the recorder's topics; callbacks that do nothing."""

        def __init__(self, *, context):
            super().__init__('raw_listener', context=context)
            self._subscriptions_by_topic = {}
            self.create_timer(1.0, self.discover)
            self.discover()

        def discover(self) -> None:
            for name, types in self.get_topic_names_and_types():
                if name in self._subscriptions_by_topic or len(types) != 1 or not (
                        name == DIAGNOSTICS or name.startswith(args.namespace.rstrip('/') + '/')):
                    continue
                infos = self.get_publishers_info_by_topic(name)
                if not infos:
                    continue
                qos = subscription_qos(request_for_offers(tuple(qos_spec(i.qos_profile) for i in infos),
                                                          depth=100))
                self._subscriptions_by_topic[name] = self.create_subscription(
                    message_class(types[0]), name, lambda data: None, qos, raw=True)

    # run_nodes: SIGINT/SIGTERM end the spin between slices (rclpy's own handler would shut the
    # context down under the spinning EventsExecutor, which can hang it)
    run_nodes([RawListener], ['raw_listener'])


if __name__ == '__main__':
    main()
