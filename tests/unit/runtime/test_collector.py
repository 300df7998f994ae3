"""The garbage collector kept off the command path: objects alive at a freeze are not collected
until thawed; the startup freeze first collects the garbage there is."""

import gc
import weakref

import pytest

from rrps_runtime.collector import freeze_new_objects, freeze_startup_objects, thaw


class _Cycle:
    """An object in a reference cycle: only the cyclic collector frees it."""

    def __init__(self):
        self.me = self


@pytest.fixture(autouse=True)
def _thawed():
    thaw()
    yield
    thaw()


@pytest.mark.parametrize('freeze', [freeze_startup_objects, freeze_new_objects])
def test_objects_alive_at_a_freeze_outlive_collections_until_thawed(freeze):
    obj = _Cycle()
    ref = weakref.ref(obj)
    freeze()
    del obj
    assert gc.get_freeze_count() > 0
    gc.collect()
    assert ref() is not None
    thaw()
    assert gc.get_freeze_count() == 0
    gc.collect()
    assert ref() is None


def test_the_startup_freeze_collects_the_garbage_first():
    garbage = _Cycle()
    ref = weakref.ref(garbage)
    del garbage
    freeze_startup_objects()
    assert ref() is None
