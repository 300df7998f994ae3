"""The robots a viewer shows (one, or each of a fleet) and the one it draws: of every robot its statuses, of the
drawn one also its pose, actuators, target and odometry, from its own topics or its link relay (``source`` = 'link').
Callbacks only store (the drawing thread reads)."""

from __future__ import annotations

import math
import threading
import time
from typing import Callable, Sequence

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState

from rrps_interfaces.climb import CLIMB_PREVIEW, CLIMB_STATUS, odometry_topic
from rrps_interfaces.driver import GRIPPERS_STATE
from rrps_interfaces.kinematics import ACTUATORS_STATE, POSE, TARGET_POSE
from rrps_interfaces.link import namespaced, normalize_namespace, robot_topic
from rrps_interfaces.status import DIAGNOSTICS, source_node
from rrps_interfaces.teleop import TELEOP_STATUS
from rrps_runtime.qos import COMMAND_QOS, LATCHED_QOS, LATEST_QOS, LINK_EVENT_QOS, LINK_STATE_QOS, STATE_QOS
from rrps_viewer import status_text as panel

__all__ = ['ViewerRobots', 'DRIVER', 'FK']

DRIVER = 'driver'
FK = 'fk'
#: the statuses of the robot's nodes that the viewer keeps (node name -> key)
_STATUS_NODES = {'driver_node': DRIVER, 'fk_node': FK}
#: the selected robot's topics: (topic, type, QoS read directly)
_DRAWN = ((POSE, PoseStamped, LATEST_QOS), (ACTUATORS_STATE, JointState, LATEST_QOS),
          (TARGET_POSE, PoseStamped, COMMAND_QOS),
          *((odometry_topic(ring), PoseStamped, STATE_QOS) for ring in ('ring_a', 'ring_b')))


class ViewerRobots:
    """The robots of a viewer (module docstring). ``on_drawn(topic, msg)`` receives the
    selected robot's drawn topics (relative names as keys)."""

    def __init__(self, node, robots: Sequence[str] | None, source: str, on_drawn: Callable[[str, object], None]):
        self._node = node
        self.source = source
        self._on_drawn = on_drawn
        own = node.get_namespace()
        names = [normalize_namespace(r) for r in robots or ()] or ['']
        self.robots = ['' if r == own else r for r in names]
        if len(set(self.robots)) != len(self.robots):
            raise ValueError(f'robots names a robot twice: {list(robots)}')
        self._absolute = {r: r or own for r in self.robots}
        self._lock = threading.Lock()
        self._latest: dict[str, dict] = {r: {} for r in self.robots}
        self._heard: dict[str, float] = {r: -math.inf for r in self.robots}
        link = source == 'link'
        for robot in self.robots:
            for topic, kind, qos in ((CLIMB_STATUS, DiagnosticStatus, STATE_QOS),
                                     (CLIMB_PREVIEW, DiagnosticStatus, LATCHED_QOS),
                                     (TELEOP_STATUS, DiagnosticStatus, STATE_QOS)):
                node.create_subscription(kind, namespaced(topic, robot),
                                         lambda msg, r=robot, k=topic: self._store(r, k, msg), qos)
            node.create_subscription(JointState, robot_topic(GRIPPERS_STATE, robot, source),
                                     lambda msg, r=robot: self._store(r, GRIPPERS_STATE, msg),
                                     LINK_EVENT_QOS if link else STATE_QOS)
            # its nodes' statuses: from its relay, from /diagnostics (one robot) or from its
            # namespace (a fleet's robot: -r /diagnostics:=diagnostics)
            node.create_subscription(DiagnosticArray, robot_topic(DIAGNOSTICS, robot, source),
                                     lambda msg, r=robot: self._on_diagnostics(r, msg),
                                     LINK_EVENT_QOS if link else STATE_QOS)
        self.selected = self.robots[0]
        self._drawn: list = []
        self.select(self.selected)

    def _store(self, robot: str, key: str, msg) -> None:
        with self._lock:
            self._latest[robot][key] = msg
            self._heard[robot] = time.monotonic()

    def _on_diagnostics(self, robot: str, msg: DiagnosticArray) -> None:
        for status in msg.status:
            key = _STATUS_NODES.get(source_node(status.name))
            if key is not None:
                self._store(robot, key, status)

    def select(self, robot: str) -> None:
        """Draw the robot ``robot`` (one of :attr:`robots`) from now on: its drawn topics are read
        instead of the previous robot's. Runs on the executor's thread."""
        if robot not in self._latest:
            raise ValueError(f'unknown robot {robot!r}; robots: {self.robots}')
        for subscription in self._drawn:
            self._node.destroy_subscription(subscription)
        link = self.source == 'link'
        self._drawn = [self._node.create_subscription(
            kind, robot_topic(topic, robot, self.source), lambda msg, topic=topic: self._on_drawn(topic, msg),
            LINK_STATE_QOS if link else qos) for topic, kind, qos in _DRAWN]
        self.selected = robot

    def name(self, robot: str) -> str:
        """A robot's name for people: the last part of its namespace."""
        return self._absolute[robot].rsplit('/', 1)[-1] or '/'

    def absolute(self, robot: str) -> str:
        return self._absolute[robot]

    def latest(self, robot: str | None = None) -> dict:
        """The newest summary messages of ``robot`` (default: the selected one)."""
        with self._lock:
            return dict(self._latest[self.selected if robot is None else robot])

    def heard(self, robot: str) -> float | None:
        """Seconds since anything of ``robot`` was heard (None: never)."""
        with self._lock:
            t = self._heard[robot]
        return None if t == -math.inf else time.monotonic() - t

    def heard_count(self, within: float) -> int:
        """How many robots were heard in the last ``within`` s."""
        return sum((h := self.heard(r)) is not None and h < within for r in self.robots)

    def panel_lines(self) -> list[str]:
        """The panel's fleet list: one line per robot (driven or holding, driver, climb,
        grippers, when it was last heard)."""
        lines = ['**Robots:**']
        for robot in self.robots:
            summary = self.latest(robot)
            driven, engaged = panel.driven_robot(summary.get(TELEOP_STATUS))
            grippers: dict[str, float | None] = {'ring_a': None, 'ring_b': None}
            msg = summary.get(GRIPPERS_STATE)
            if msg is not None:
                grippers.update({n: float(v) for n, v in zip(msg.name, msg.position) if n in grippers})
            is_driven = driven == self._absolute[robot]
            lines.append('- ' + panel.robot_line(
                self.name(robot), selected=robot == self.selected, driven=is_driven,
                engaged=is_driven and engaged, driver=summary.get(DRIVER), climb=summary.get(CLIMB_STATUS),
                grippers=grippers, heard=self.heard(robot)))
        return lines
