"""Parameter schemas (rrps_runtime.parameter_schema): values written so that YAML (PyYAML, as
rrps_bringup.params reads the files) reads them back as the same value and type, lists of
strings and of ints, unset lists, empty strings, and the checks of a declaration."""

from __future__ import annotations

import math

import pytest
import yaml

from rrps_runtime.parameter_schema import NodeParameters, Parameter, format_value

ROUND_TRIP = [0.1, 1e-12, 1e-3, 2e-4, 1e9, 1e20, -1.0, 30.0, 0.0, math.inf, -math.inf, 8080, True, False,
              'pole', '127.0.0.1', 'ring_a', '', 'true', 'null', '1e-3', '8080', 'a: b', '[x', ' padded',
              "it's", (4.0, 4.0), (0.0, -0.9, 0.0), ('',), ('/rrps', 'a, b')]


@pytest.mark.parametrize('value', ROUND_TRIP, ids=repr)
def test_a_written_value_reads_back_as_itself(value):
    read = yaml.safe_load(f'key: {format_value(value)}')['key']
    expected = list(value) if isinstance(value, tuple) else value
    assert read == expected and type(read) is type(expected)
    if isinstance(value, tuple):
        assert [type(v) for v in read] == [type(v) for v in expected]


def test_nan_is_written_as_yaml_nan():
    assert math.isnan(yaml.safe_load(f'key: {format_value(math.nan)}')['key'])


def test_list_parameters_hold_numbers_or_strings():
    assert Parameter('origin', (0.0, -0.9, 0.0), 'a position').item_type is float
    assert Parameter('files', ('',), 'files').item_type is str
    assert Parameter('speed', 1.0, 'a speed').item_type is None
    with pytest.raises(ValueError, match='holds floats'):
        Parameter('mixed', (1.0, 'a'), 'mixed')
    with pytest.raises(ValueError, match='range needs a number type'):
        Parameter('files', ('a',), 'files', range=(0.0, 1.0))


@pytest.mark.parametrize('kwargs, message', [
    (dict(name='x', default=None, description='no type'), 'needs its type'),
    (dict(name='x', default=2.0, description='d', range=(0.0, 1.0)), r'x must be in \[0, 1\], got 2.0'),
    (dict(name='x', default='c', description='d', choices=('a', 'b')), 'x must be one of a | b'),
    (dict(name='x', default=1.0, description='d', choices=('a',)), 'choices are for strings'),
    (dict(name='x', default=1, description='d', type=float), 'is not a float'),
])
def test_a_wrong_declaration_is_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Parameter(**kwargs)


def test_the_file_holds_every_set_default_and_notes_the_unset_one():
    schema = NodeParameters('some_node', 'some_package', [
        Parameter('files', ('',), 'recordings'),
        Parameter('token', '', 'empty: generate one'),
        Parameter('tolerance', 1e-12, 'residual', unit='m', range=(1e-15, 1e-3), dynamic=True),
        Parameter('halt', None, 'threshold', type=float, unset_note="the robot's value"),
    ])
    text = schema.config_yaml()
    values = yaml.safe_load(text)['/**/some_node']['ros__parameters']
    assert values == {'files': [''], 'token': '', 'tolerance': 1e-12}
    assert "# halt: unset here: the robot's value" in text
    assert '| `halt` | the robot\'s value |' in schema.markdown()
    with pytest.raises(ValueError, match='declared twice'):
        NodeParameters('n', 'p', [Parameter('a', 1.0, 'a'), Parameter('a', 2.0, 'a')])


def test_a_list_of_ints_is_checked_item_by_item():
    legs = Parameter('stuck_legs', None, 'legs', type=tuple, item_type=int, range=(1, 6), dynamic=True,
                     unset_note='none')
    legs.check((1, 6))
    with pytest.raises(ValueError, match=r'stuck_legs must be in \[1, 6\], got \(7,\)'):
        legs.check((7,))
    assert legs.constraints() == '[1 .. 6]'
    with pytest.raises(ValueError, match='holds ints'):
        Parameter('legs', (1.5,), 'legs', item_type=int)
    with pytest.raises(ValueError, match='floats, ints or strings'):
        Parameter('legs', (), 'legs', item_type=bool)


def test_the_generated_file_keeps_an_empty_string_and_leaves_unset_lists_out():
    schema = NodeParameters('n', 'p', [
        Parameter('state_file', '', 'a file; empty: none'),
        Parameter('initial', None, 'initial lengths', unit='m', type=tuple, unset_note='the home pose'),
        Parameter('seed', 0, 'a seed', range=(0, 2**31 - 1)),
    ])
    text = schema.config_yaml()
    assert yaml.safe_load(text)['/**/n']['ros__parameters'] == {'state_file': '', 'seed': 0}
    assert '# initial: unset here: the home pose' in text and '[0 .. 2147483647]' in text
