"""The viewer's status lines (viewer/status_text) from the typed statuses: a step being previewed,
a refused one, what its preview predicted, and a status that never came or does not parse."""

from __future__ import annotations

from types import SimpleNamespace

from rrps_interfaces.climb import ClimbPreview, ClimbState, ClimbStatus, PreviewLimit, StepRefusal
from rrps_viewer.status_text import (
    DEFAULT_SCALE,
    climb_line,
    driven_robot,
    driver_line,
    feedback_line,
    preview_line,
    teleop_line,
    translation_scale,
)


def _status(values, level=0):
    return SimpleNamespace(level=level, values=[SimpleNamespace(key=k, value=v) for k, v in values.to_values().items()])


def test_the_climb_line_says_a_step_is_previewed_or_was_refused():
    assert climb_line(_status(ClimbStatus(ClimbState.IDLE, previewing=True))) == 'idle: previewing the step (OK)'
    refused = ClimbStatus(ClimbState.IDLE, refusal=StepRefusal.PREVIEW_LIMIT)
    assert climb_line(_status(refused, level=1)) == 'idle: step refused (preview limit) (WARN)'


def test_the_preview_line_gives_the_peak_force_the_gripper_reaction_and_the_margin():
    ok = ClimbPreview(accepted=True, peak_force=44.07, peak_leg=2, max_force=2000.0, peak_reaction_force=240.2,
                      peak_reaction_moment=5.37, min_margin=0.6797, min_margin_ring='ring_a')
    assert preview_line(_status(ok)) == ('accepted: peak force 44 N (leg_2, max 2000 N), gripper reaction 240 N '
                                         '/ 5 N m, holding margin 0.68 (ring_a)')
    broken = ClimbPreview(accepted=False, peak_force=2500.0, peak_leg=4, max_force=2000.0,
                          limit=PreviewLimit.ACTUATOR_FORCE)
    assert preview_line(_status(broken)).startswith('REFUSED (actuator force): peak force 2500 N (leg_4')
    assert preview_line(_status(broken)).endswith('holding margin —')
    failed = ClimbPreview(accepted=False, detail='preview failed: singular')
    assert preview_line(_status(failed)) == 'preview failed: singular'
    assert preview_line(None) == '—'
    assert preview_line(SimpleNamespace(level=0, values=[])).startswith('unreadable')


def test_every_line_says_when_no_status_came_or_it_does_not_parse():
    unreadable = SimpleNamespace(level=0, values=[SimpleNamespace(key=k, value='not a value') for k in (
        'code', 'state', 'mode', 'active', 'accepted', 'engaged')])
    for line in (teleop_line, climb_line, preview_line):
        assert line(None) == '—'
        assert line(unreadable).startswith('unreadable ('), line
    assert driver_line(None) == 'not heard yet'
    assert driver_line(unreadable).startswith('unreadable (')
    for status in (None, unreadable):
        assert feedback_line(status) is None
        assert translation_scale(status) == DEFAULT_SCALE
        assert driven_robot(status) == (None, False)
