"""Parameter files (config/<node>.yaml): each loads into its node with ``--params-file`` (rcl's
own parsing, the ``/**/<node>`` section in a namespace), holds every parameter the node
declares, and its values take effect (a copy with changed values is loaded too). Every node
declares its parameters in a schema, the shipped files and docs/parameters.md are what the
schemas generate, and a value outside a parameter's range or choices is refused."""

from __future__ import annotations

import re

import pytest
import yaml

from rrps_bringup import params
from rrps_bringup.params import config_file, parameter_overrides
from rrps_bringup.registry import registered_nodes
from rrps_runtime.parameter_schema import NodeParameters
from rrps_testing.processes import free_port

pytestmark = pytest.mark.ros

#: One value per node that differs from the shipped default: proves the file is read.
CHANGED = {
    'ik_node': {'timeout': 0.2}, 'fk_node': {'max_iterations': 25},
    'driver_node': {'rate': 400.0, 'sensor_noise': 1e-6}, 'master_node': {'rate': 150.0},
    'teleop_node': {'translation_scale': 3.0}, 'climb_node': {'speed': 0.03},
    'viewer_node': {'render_rate': 30.0}, 'recorder_node': {'buffer_seconds': 30.0},
    'replay_node': {'rate': 2.0}, 'markers_node': {'rate': 5.0}, 'foxglove_node': {'max_rate': 10.0},
    'link_relay_node': {'pose_rate': 25.0},
    'robot_description_node': {'rate': 10.0},
}
#: Declared but deliberately not in the files (rclpy's own, or robot-dependent defaults).
NOT_IN_FILES = {'use_sim_time', 'start_type_description_service', 'singularity_halt'}


def _section(path) -> dict:
    data = yaml.safe_load(path.read_text())
    [key] = data
    return key, data[key]['ros__parameters']


def _start(node_name, params_file, domain_id, tmp_path):
    import rclpy

    from rrps_bringup.registry import node_class
    from rrps_recording.storage.mcap_files import TopicInfo, write_recording
    extra = []
    if node_name in ('viewer_node', 'foxglove_node'):
        extra = ['-p', f'port:={free_port()}']
    elif node_name == 'replay_node':
        path = write_recording(tmp_path / 'one.mcap', [TopicInfo('/x', 'std_msgs/msg/Bool')],
                               [('/x', 1, b'\x00\x01\x00\x00\x01')])
        extra = ['-p', f'files:=[{path}]']
    elif node_name == 'recorder_node':
        extra = ['-p', f'output_dir:={tmp_path}']
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id,
               args=['test', '--ros-args', '--params-file', str(params_file), *extra])
    try:
        node = node_class(node_name)(context=context, namespace='/rrps')
    except BaseException:
        rclpy.shutdown(context=context)
        raise
    return context, node


def _check(node, values: dict, skip=()) -> None:
    for name, value in values.items():
        if name in skip:
            continue
        assert node.has_parameter(name), f'{node.get_name()} declares no {name!r}'
        got = node.get_parameter(name).value
        if isinstance(value, list):
            got = list(got)
        if isinstance(value, float) and isinstance(got, float):
            assert got == pytest.approx(value, rel=1e-12), name
            continue
        assert got == value, (name, got, value)


@pytest.mark.parametrize('node_name', sorted(registered_nodes()))
def test_each_parameter_file_loads_into_its_node(node_name, ros_domain_id, tmp_path):
    import rclpy

    path = config_file(node_name)
    assert path.parent.name == 'config' and path.parent.parent.name == 'rrps_bringup'
    key, values = _section(path)
    assert key == f'/**/{node_name}'
    skip = {'port', 'files', 'output_dir'}  # given on the command line above
    context, node = _start(node_name, path, ros_domain_id, tmp_path)
    try:
        _check(node, values, skip)
        declared = {n for n, p in node.get_parameters_by_prefix('').items()
                    if p.type_ != p.Type.NOT_SET}
        missing = declared - set(values) - NOT_IN_FILES
        assert not missing, f'{path.name} lacks {sorted(missing)}'
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)
    # the in-process form the demo uses gives the same values
    overrides = {p.name: p.value for p in parameter_overrides(node_name)}
    assert {k: (list(v) if not isinstance(v, (str, bool, int, float)) else v)
            for k, v in overrides.items()} == values

    changed = dict(values, **CHANGED[node_name])
    assert changed != values
    copy = tmp_path / f'{node_name}.yaml'
    copy.write_text(yaml.safe_dump({key: {'ros__parameters': changed}}))
    context, node = _start(node_name, copy, ros_domain_id, tmp_path)
    try:
        _check(node, changed, skip)
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)


@pytest.mark.parametrize('node_name', sorted(registered_nodes()))
def test_each_node_declares_its_parameters_in_a_schema(node_name):
    node = registered_nodes()[node_name]
    schema = node.parameters()
    assert isinstance(schema, NodeParameters), f'{node.module} has no PARAMETERS schema'
    assert (schema.node, schema.package) == (node_name, node.package)


def test_shipped_files_are_what_the_schemas_generate(capsys):
    assert params.main(['--check']) == 0, capsys.readouterr().out


def test_a_hosting_node_ships_the_default_hardware_and_documents_each():
    """driver_node.yaml: the driver's own parameters, then the simulated robot's (the default
    hardware); docs/parameters.md: a table per registered hardware that has parameters."""
    from rrps_sim.simulated_robot import SimulatedRobot
    _, values = _section(config_file('driver_node'))
    own = registered_nodes()['driver_node'].parameters()
    assert own['hardware'].default == 'simulated'
    assert list(values) == [p.name for p in (*own, *SimulatedRobot.PARAMETERS) if p.default is not None]
    doc = params.PARAMETERS_DOC.read_text()
    assert '#### driver_node with `hardware: simulated` (rrps_sim)' in doc
    assert '`hardware: canopen`' not in doc  # the CANopen hardware has no parameter of its own


def test_check_finds_a_stale_file_and_write_renews_it(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(params, 'SOURCE_CONFIG', tmp_path / 'config')
    monkeypatch.setattr(params, 'PARAMETERS_DOC', tmp_path / 'parameters.md')
    (tmp_path / 'config').mkdir()
    assert params.main(['--write']) == 0
    assert params.main(['--check']) == 0
    shipped = tmp_path / 'config' / 'ik_node.yaml'
    assert shipped.read_text() == config_file('ik_node').read_text()
    shipped.write_text(shipped.read_text().replace('timeout: 0.1', 'timeout: 0.2'))
    capsys.readouterr()
    assert params.main(['--check']) == 1
    assert capsys.readouterr().out.strip() == f'differs from its schema: {shipped}'


def test_a_value_outside_its_range_or_choices_is_refused_with_the_reason(ros_context):
    from rclpy.parameter import Parameter

    from rrps_teleop.nodes.master_node import MasterNode
    node = MasterNode(context=ros_context, namespace='/rrps')
    try:
        refused = {
            'trajectory': ('square', 'trajectory must be one of none | circle | lissajous'),
            'amplitude': (0.5, 'amplitude out of range'),
            'rate': (100.0, 'read-only'),
        }
        for name, (value, reason) in refused.items():
            [result] = node.set_parameters([Parameter(name, value=value)])
            assert not result.successful and reason in result.reason, (name, result.reason)
        assert (node.trajectory, node.amplitude, node.rate) == ('none', 0.005, 200.0)
        results = node.set_parameters([Parameter('trajectory', value='circle'),
                                       Parameter('amplitude', value=0.01)])
        assert all(r.successful for r in results)
        assert (node.trajectory, node.amplitude) == ('circle', 0.01)
    finally:
        node.destroy_node()


def test_a_value_outside_its_choices_stops_the_node_at_start(ros_domain_id):
    import rclpy

    from rrps_teleop.nodes.master_node import MasterNode
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain_id,
               args=['test', '--ros-args', '-p', 'trajectory:=square'])
    try:
        with pytest.raises(ValueError, match=re.escape('trajectory must be one of none | circle | lissajous')):
            MasterNode(context=context, namespace='/rrps')
    finally:
        rclpy.shutdown(context=context)


def test_a_parameter_the_node_derives_shows_the_derived_value_and_is_settable(ros_context):
    from rclpy.parameter import Parameter

    from rrps_teleop.nodes.teleop_node import TeleopNode
    node = TeleopNode(context=ros_context, namespace='/rrps')
    try:  # singularity_halt: unset in the file, the robot's min_conditioning
        assert node.get_parameter('singularity_halt').value == node.geometry.min_conditioning
        assert node.mapping.config.singularity_halt == node.geometry.min_conditioning
        for value, reason in (('high', 'type'), (1.5, 'out of range')):
            [result] = node.set_parameters([Parameter('singularity_halt', value=value)])
            assert not result.successful and reason in result.reason.lower(), result.reason
        [result] = node.set_parameters([Parameter('singularity_halt', value=0.05)])
        assert result.successful and node.mapping.config.singularity_halt == 0.05
    finally:
        node.destroy_node()
    node = TeleopNode(context=ros_context, namespace='/rrps',
                      parameter_overrides=[Parameter('singularity_halt', value=0.03)])
    try:
        assert node.mapping.config.singularity_halt == 0.03
    finally:
        node.destroy_node()
