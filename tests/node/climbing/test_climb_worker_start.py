"""After the install's numba warm-up (``python -m rrps_bringup.warm_up``), climb_node's step worker
starts without compiling a kernel: every kernel its start loads comes from numba's disk cache, with
the argument types the node's worker passes (pickled into a spawned process). Without that, the
worker's start compiled for about a minute after an install and the first step waited for it.

numba's ``NUMBA_DEBUG_CACHE`` prints, in the worker, each kernel it loaded ('data loaded from') and
each it compiled and saved ('data saved to')."""

from __future__ import annotations

import os
import subprocess
import sys
import threading

import pytest

from rrps_climbing.climb_planner import climb_planner, preview_config, step_machine
from rrps_climbing.nodes.climb_node import PARAMETERS
from rrps_climbing.step_worker import StepWorker
from rrps_description.geometry import load_robot
from rrps_kinematics.backend import numba_enabled
from rrps_testing.ci import require

pytestmark = pytest.mark.slow


def test_the_step_worker_starts_on_the_kernels_the_install_compiled(monkeypatch, capfd):
    require(numba_enabled(), 'numba is off')
    warm_up = subprocess.run([sys.executable, '-m', 'rrps_bringup.warm_up'], capture_output=True, text=True,
                             timeout=900, env=dict(os.environ))
    assert warm_up.returncode == 0, warm_up.stderr[-3000:]
    capfd.readouterr()
    monkeypatch.setenv('NUMBA_DEBUG_CACHE', '1')   # read by the spawned worker's numba
    values = {**PARAMETERS.defaults(), 'robot': 'pole_climber'}   # as climb_node makes its worker
    geometry = load_robot(values['robot'])
    planner = climb_planner(geometry, values)
    machine = step_machine(planner, values)
    worker = StepWorker(planner, machine.plan_request(machine.step_length, 1), geometry, preview_config(values))
    ready = threading.Event()
    worker.when_ready(lambda seconds: ready.set())
    try:
        assert ready.wait(600), 'the worker did not start'
    finally:
        worker.shutdown()
    out = capfd.readouterr().out
    loaded = [line for line in out.splitlines() if 'data loaded from' in line]
    compiled = [line for line in out.splitlines() if 'data saved to' in line]
    assert loaded, out[-3000:]   # the worker's start loads kernels (and numba reports them)
    assert not compiled, '\n'.join(compiled)
