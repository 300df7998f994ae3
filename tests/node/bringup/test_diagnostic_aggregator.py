"""The diagnostic_aggregator analyzers of ``config/diagnostics/diagnostic_aggregator.yaml``: rcl
loads the file into a node named ``analyzers`` (the aggregator's), and every status a node of the
stack reports on /diagnostics is matched by exactly one GenericAnalyzer, the one of the group its
``hardware_id`` names; no analyzer is left without a status.

Matching is diagnostic_aggregator's own, written again here from its source (``ros2-jazzy``
branch, ``src/generic_analyzer.cpp``: ``find_and_remove_prefix`` sets ``startswith`` and the
chaff; ``match`` is regex, expected, name, startswith (``name.find(s) == 0``) or contains), and
the output name is ``removeLeadingNameChaff`` of ``status_item.hpp``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

from rrps_bringup.params import parameter_overrides
from rrps_bringup.registry import node_class, registered_nodes
from rrps_testing.processes import free_port

pytestmark = pytest.mark.ros

CONFIG = Path(__file__).resolve().parents[3] / 'src' / 'rrps_bringup' / 'config' / 'diagnostics' \
    / 'diagnostic_aggregator.yaml'
#: The group of each hardware_id (the robot's name: the shipped default robot).
GROUPS = {'pole_climber': 'Robot', 'operator_station': 'Operator station', 'observer': 'Observers'}


def _as_list(value) -> list[str]:
    return [value] if isinstance(value, str) else list(value or [])


def _leaves(tree: dict, path: str) -> list[tuple[str, dict]]:
    """(full path, parameters) of every GenericAnalyzer under an analyzers mapping."""
    out = []
    for key, analyzer in tree.items():
        if not isinstance(analyzer, dict):
            continue
        kind = analyzer['type']
        where = f'{path}/{analyzer["path"]}'
        if kind == 'diagnostic_aggregator/AnalyzerGroup':
            out += _leaves(analyzer['analyzers'], where)
        else:
            assert kind == 'diagnostic_aggregator/GenericAnalyzer', (key, kind)
            out.append((where, analyzer))
    return out


def _matches(analyzer: dict, name: str) -> bool:
    startswith = _as_list(analyzer.get('startswith')) + _as_list(analyzer.get('find_and_remove_prefix'))
    return (any(re.fullmatch(r, name) for r in _as_list(analyzer.get('regex')))
            or name in _as_list(analyzer.get('expected')) + _as_list(analyzer.get('name'))
            or any(name.startswith(s) for s in startswith)
            or any(s in name for s in _as_list(analyzer.get('contains'))))


def _output_name(analyzer: dict, full_name: str) -> str:
    """removeLeadingNameChaff of the item's name ``<path>/<status name>`` for each chaff."""
    out = full_name
    for chaff in _as_list(analyzer.get('find_and_remove_prefix')) + _as_list(analyzer.get('remove_prefix')):
        chaff = chaff.replace('/', ' ')
        last = out.rfind('/')
        start = out[:last] + '/'
        if out.find(chaff) == last + 1:
            out = out[:last + 1] + out[last + 1 + len(chaff):]
        if out.find(':', last) == last + 1:
            out = start + out[last + 2:]
        while out.find(' ', last) == last + 1:
            out = start + out[last + 2:]
    return out


def _node_statuses(context, tmp_path) -> dict[str, list[tuple[str, str]]]:
    """{node: [(status name, hardware_id)]} of every registered node, built as the demo builds
    it (its parameter file), for each driver mode."""
    from rclpy.parameter import Parameter

    from rrps_recording.storage.mcap_files import TopicInfo, write_recording
    from rrps_runtime.diagnostics import Diagnostics
    recording = write_recording(tmp_path / 'one.mcap', [TopicInfo('/x', 'std_msgs/msg/Bool')],
                                [('/x', 1, b'\x00\x01\x00\x00\x01')])
    extra = {'viewer_node': {'port': free_port()}, 'foxglove_node': {'port': 0},
             'replay_node': {'files': [str(recording)]}, 'recorder_node': {'output_dir': str(tmp_path)}}
    variants = {'driver_node': [{'mode': 'kinematic'}, {'mode': 'dynamic'}]}
    out = {}
    for name in registered_nodes():
        for variant in variants.get(name, [{}]):
            overrides = {p.name: p.value for p in parameter_overrides(name)}
            overrides.update(extra.get(name, {}), **variant)
            node = node_class(name)(context=context, namespace='/rrps', parameter_overrides=[
                Parameter(k, value=v) for k, v in overrides.items()])
            try:
                out.setdefault(name, []).extend(
                    (d.name, d.hardware_id) for d in vars(node).values() if isinstance(d, Diagnostics))
            finally:
                node.destroy_node()
    return out


def test_rcl_loads_the_analyzers_into_the_aggregators_node(ros_domain_id):
    import rclpy
    from rclpy.node import Node

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain_id,
               args=['test', '--ros-args', '--params-file', str(CONFIG)])
    try:
        node = Node('analyzers', context=context, automatically_declare_parameters_from_overrides=True)
        try:
            assert node.get_parameter('path').value == 'rrps'
            assert node.get_parameter('robot.type').value == 'diagnostic_aggregator/AnalyzerGroup'
            assert list(node.get_parameter('robot.analyzers.kinematics.find_and_remove_prefix').value) == \
                ['ik_node:', 'fk_node:']
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def test_every_status_is_matched_by_exactly_one_analyzer_of_its_hardware_group(ros_context, tmp_path):
    params = yaml.safe_load(CONFIG.read_text())['analyzers']['ros__parameters']
    leaves = _leaves({k: v for k, v in params.items() if k != 'path'}, '/' + params['path'])
    statuses = _node_statuses(ros_context, tmp_path)
    assert {'ik_node', 'fk_node', 'driver_node', 'teleop_node', 'climb_node', 'master_node',
            'recorder_node', 'replay_node', 'foxglove_node'} <= {n for n, s in statuses.items() if s}
    used = set()
    for node, reported in statuses.items():
        for name, hardware_id in reported:
            assert name.startswith(f'{node}: ') and hardware_id in GROUPS, (name, hardware_id)
            matched = [(path, a) for path, a in leaves if _matches(a, name)]
            assert len(matched) == 1, (name, [p for p, _ in matched])
            [(path, analyzer)] = matched
            assert path.split('/')[2] == GROUPS[hardware_id], (name, path)
            shown = _output_name(analyzer, f'{path}/{name}')
            assert shown == f'{path}/{name.split(": ", 1)[1]}', shown
            used.add(path)
    assert used == {path for path, _ in leaves}, 'an analyzer matches no status'
