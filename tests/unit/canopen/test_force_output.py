"""The master's force output is bounded and passive: under a wanted force that steps and
oscillates, on a leg held by a hand (mass, spring, damper, integrated here independently of the
output), the force never exceeds its limit and the work the drive does on the hand never
exceeds zero by more than one period's worth."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_canopen.force_output import PassiveForceOutput

DT = 0.002


def run(wanted, *, limit=5.0, damping=2.0, mass=0.3, stiffness=300.0, hand_damping=0.5, seconds=6.0):
    """Six legs; returns (forces (n, 6), the drive's work on the hand over time (n, 6))."""
    out = PassiveForceOutput(6, limit=limit, damping=damping)
    x, v = np.zeros(6), np.zeros(6)
    forces, work = [], []
    w = np.zeros(6)
    for k in range(int(seconds / DT)):
        f = out(wanted(k * DT), x, v, DT)
        for _ in range(4):  # the hand and the leg between two samples
            a = (f - stiffness * x - hand_damping * v) / mass
            v_new = v + DT / 4 * a
            x_new = x + DT / 4 * v_new
            w = w + f * (x_new - x)
            x, v = x_new, v_new
        forces.append(f)
        work.append(w.copy())
    return np.array(forces), np.array(work)


def oscillating(t):
    phases = np.arange(6) * 0.7
    return 8.0 * np.sin(2 * np.pi * 9.0 * t + phases) * (t > 0.5)


def step(t):
    return np.where(t > 0.5, [6.0, -6.0, 3.0, -3.0, 0.5, 10.0], 0.0)


@pytest.mark.parametrize('wanted', [step, oscillating, lambda t: step(t) + oscillating(t)])
def test_bounded_and_passive(wanted):
    forces, work = run(wanted)
    assert np.abs(forces).max() <= 5.0 + 1e-12
    one_period = 5.0 * 5.0 / 0.3 * DT ** 2  # what a period's lag can let through: F * (F/m dt) dt
    assert work.max() <= one_period, work.max()


def test_without_the_passivity_control_the_oscillation_would_inject_energy():
    """The check can fail: the same force only saturated and damped, resonating with the hand,
    does work on it."""
    x, v, w = np.zeros(6), np.zeros(6), np.zeros(6)
    for k in range(3000):
        f = np.clip(oscillating(k * DT) - 2.0 * v, -5.0, 5.0)
        for _ in range(4):
            a = (f - 300.0 * x - 0.5 * v) / 0.3
            v2 = v + DT / 4 * a
            x2 = x + DT / 4 * v2
            w += f * (x2 - x)
            x, v = x2, v2
    assert w.max() > 0.01


def test_a_force_against_a_still_hand_is_rendered_as_asked():
    out = PassiveForceOutput(6, limit=5.0, damping=2.0)
    assert np.allclose(out(np.full(6, 3.0), np.zeros(6), np.zeros(6), DT), 3.0)
    assert np.allclose(out(np.full(6, 30.0), np.zeros(6), np.zeros(6), DT), 5.0)


def test_a_hand_pushing_into_a_wall_feels_it():
    """The operator moves the leg into a virtual wall and back, three times: while the hand pushes
    in, the wall's force is rendered (the drive absorbs; damping aside), and the drive never gave
    more than a period lets through."""
    damping = 2.0
    out = PassiveForceOutput(1, limit=5.0, damping=damping)
    pushing, felt, given = 0, 0, 0.0
    previous = None
    for k in range(1500):
        t = k * DT
        x = np.array([0.01 * np.sin(2 * np.pi * t)])
        v = np.array([0.02 * np.pi * np.cos(2 * np.pi * t)])
        wanted = np.where(x > 0, -200.0 * x, 0.0)
        f = out(wanted, x, v, DT)
        if previous is not None:
            given += float(previous[1] * (x - previous[0])[0])
            assert given <= 5.0 * 5.0 / 0.3 * DT ** 2
        previous = (x, f[0])
        if x[0] > 0 and v[0] > 0:
            pushing += 1
            felt += abs(f[0] - (wanted[0] - damping * v[0])) < 1e-9
    assert felt >= 0.9 * pushing, (felt, pushing)
