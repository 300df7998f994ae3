"""The Foxglove layout shipped for the stack (``rrps_bringup/config/foxglove/rrps_layout.json``,
Foxglove's "Import layout" format): every panel of the arrangement is configured, and every
message path it plots or shows names a topic the stack publishes (with the stack's default
namespace) and fields its message type has."""

from __future__ import annotations

import json
import re
from pathlib import Path

from rrps_interfaces.climb import CLIMB_STATUS, ODOMETRY
from rrps_interfaces.driver import GRIPPERS_STATE
from rrps_interfaces.kinematics import ACTUATORS_STATE
from rrps_interfaces.recording import ROBOT_MARKERS
from rrps_interfaces.status import DIAGNOSTICS
from rrps_interfaces.teleop import TELEOP_STATUS
from rrps_recording.storage.schemas import message_class

LAYOUT = Path(__file__).resolve().parents[3] / 'src' / 'rrps_bringup' / 'config' / 'foxglove' / 'rrps_layout.json'
NS = '/rrps'
TYPES = {f'{NS}/{ACTUATORS_STATE}': 'sensor_msgs/msg/JointState',
         f'{NS}/{GRIPPERS_STATE}': 'sensor_msgs/msg/JointState',
         f'{NS}/{TELEOP_STATUS}': 'diagnostic_msgs/msg/DiagnosticStatus',
         f'{NS}/{CLIMB_STATUS}': 'diagnostic_msgs/msg/DiagnosticStatus',
         f'{NS}/{ROBOT_MARKERS}': 'visualization_msgs/msg/MarkerArray',
         f'{NS}/{ODOMETRY}': 'nav_msgs/msg/Odometry',
         f'{NS}/robot_description': 'std_msgs/msg/String',
         DIAGNOSTICS: 'diagnostic_msgs/msg/DiagnosticArray'}


def _panels(tree) -> list[str]:
    if isinstance(tree, str):
        return [tree]
    assert tree['direction'] in ('row', 'column')
    return _panels(tree['first']) + _panels(tree['second'])


def _message_path(path: str) -> None:
    """A path 'topic.field[i].field' names a known topic and fields of its type."""
    topic = next(t for t in sorted(TYPES, key=len, reverse=True) if path == t or path.startswith(t + '.'))
    cls = message_class(TYPES[topic])
    for field in re.findall(r'\.([a-z_]+)', path[len(topic):]):
        fields = cls.get_fields_and_field_types()
        assert field in fields, (path, field)
        kind = re.sub(r'^sequence<(.+)>$', r'\1', fields[field]).split('[')[0]
        cls = message_class(kind.replace('/', '/msg/')) if '/' in kind else None


def test_the_layout_arranges_configured_panels_on_the_stacks_topics():
    layout = json.loads(LAYOUT.read_text())
    assert set(layout) == {'configById', 'globalVariables', 'userNodes', 'playbackConfig', 'layout'}
    panels = _panels(layout['layout'])
    assert sorted(panels) == sorted(layout['configById'])
    kinds = {p.split('!')[0] for p in panels}
    assert {'3D', 'Plot', 'StateTransitions', 'RawMessages', 'DiagnosticSummary'} <= kinds
    paths = []
    for panel, config in layout['configById'].items():
        paths += [s['value'] for s in config.get('paths', [])]
        paths += [config[k] for k in ('topicPath', 'topicToRender') if k in config]
        paths += list(config.get('topics', {}))
        paths += [layer['topic'] for layer in config.get('layers', {}).values() if 'topic' in layer]
    for path in paths:
        _message_path(path)
    plotted = {s['value'] for p, c in layout['configById'].items() if p.startswith('Plot!') for s in c['paths']}
    assert {f'{NS}/{ACTUATORS_STATE}.position[{i}]' for i in range(6)} <= plotted  # leg lengths
    assert {f'{NS}/{ACTUATORS_STATE}.effort[{i}]' for i in range(6)} <= plotted  # leg forces


def test_the_3d_panel_follows_base_link_over_the_odom_grid():
    """REP-105: the camera follows the robot's base_link; the ground grid is the world's, odom."""
    robot = json.loads(LAYOUT.read_text())['configById']['3D!robot']
    assert robot['followTf'] == 'base_link' and robot['layers']['grid']['frameId'] == 'odom'
