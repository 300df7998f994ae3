"""Parameter schemas (rrps_runtime.parameter_schema): lists of ints, unset lists, empty strings."""

from __future__ import annotations

import pytest
import yaml

from rrps_runtime.parameter_schema import NodeParameters, Parameter


def test_a_list_of_ints_is_checked_item_by_item():
    legs = Parameter('stuck_legs', None, 'legs', type=tuple, item_type=int, range=(1, 6), dynamic=True,
                     unset_note='none')
    legs.check((1, 6))
    with pytest.raises(ValueError, match=r'stuck_legs must be in \[1, 6\], got \(7,\)'):
        legs.check((7,))
    assert legs.constraints() == '[1 .. 6]'
    with pytest.raises(ValueError, match='holds ints'):
        Parameter('legs', (1.5,), 'legs', item_type=int)
    with pytest.raises(ValueError, match='floats or ints'):
        Parameter('legs', (), 'legs', item_type=str)


def test_the_generated_file_keeps_an_empty_string_and_leaves_unset_lists_out():
    schema = NodeParameters('n', 'p', [
        Parameter('state_file', '', 'a file; empty: none'),
        Parameter('initial', None, 'initial lengths', unit='m', type=tuple, unset_note='the home pose'),
        Parameter('seed', 0, 'a seed', range=(0, 2**31 - 1)),
    ])
    text = schema.config_yaml()
    assert yaml.safe_load(text)['/**/n']['ros__parameters'] == {'state_file': '', 'seed': 0}
    assert '# initial: unset here: the home pose' in text and '[0 .. 2147483647]' in text
