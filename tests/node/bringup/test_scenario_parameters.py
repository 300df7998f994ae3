"""The demo scenarios against the shipped nodes' parameter schemas: each node gets exactly the
scenario's parameters it declares (the driver: its own and the simulated robot's), each value
within that node's schema."""

from __future__ import annotations

from rrps_bringup.registry import registered_nodes
from rrps_bringup.scenarios import SCENARIOS, Scenario, scenario


def test_each_node_gets_the_parameters_it_declares_and_no_others():
    nodes = registered_nodes()
    s = scenario('pole_leaning')
    driver = s.parameters('driver_node', nodes['driver_node'].declared_parameters())
    assert driver['payload_mass'] == 40.0 and len(driver['world_q_support']) == 4
    for node in ('climb_node', 'viewer_node', 'markers_node'):
        params = s.parameters(node, nodes[node].parameters())
        assert params['structure'] == 'pole' and params['structure_lean_deg'] == 30.0, node
    assert s.parameters('ik_node', nodes['ik_node'].parameters()) == {'robot': 'pole_climber'}
    for row in SCENARIOS.values():
        for name, node in nodes.items():
            schema = node.declared_parameters()
            declared = {p.name for p in schema} if schema is not None else set()
            params = row.parameters(name, schema)
            assert set(params) == declared & set(row.world_parameters()), name
            for key, value in params.items():  # every value passes the node's own schema
                schema[key].check(value)


def test_a_new_scenario_is_a_row_with_its_structures_parameters():
    """A frame-node scenario, say: its climb-node parameters reach the climb node only."""
    row = Scenario('frame_node', robot='frame_climber', structure='frame', summary='across a node',
                   motion='ring_b along the column', handle_step=(0.0, 0.0, 0.004),
                   node_parameters=(('speed', 0.08),))
    nodes = registered_nodes()
    assert row.parameters('climb_node', nodes['climb_node'].parameters())['speed'] == 0.08
    assert 'speed' not in row.parameters('viewer_node', nodes['viewer_node'].parameters())
