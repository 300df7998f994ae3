"""rrps-climb: CSV per phase, summary, refusals (exit 1), bad arguments (exit 2)."""

from __future__ import annotations

import csv
import re
import subprocess
import sys

import numpy as np
import pytest

from rrps_climbing.cli import main


def _rows(path):
    with open(path, newline='') as f:
        return list(csv.DictReader(f))


def test_pole_800_mm_in_11_steps_csv(tmp_path, capsys):
    out = tmp_path / 'plan.csv'
    assert main(['--robot', 'pole_climber', '--structure', 'pole', '--distance', '0.8',
                 '--steps', '11', '--csv', str(out)]) == 0
    summary = capsys.readouterr().out
    assert '11 steps of 72.7 mm' in summary and 'climbed 0.800 m' in summary
    rows = _rows(out)
    for col in ('step', 'phase', 'gripper_a', 'gripper_b', 'a_x', 'a_y', 'a_z', 'b_x', 'b_y', 'b_z',
                'L1', 'L6'):
        assert col in rows[0]
    grips = np.array([(int(r['gripper_a']), int(r['gripper_b'])) for r in rows])
    assert set(grips.ravel()) <= {0, 1} and np.all(grips.max(axis=1) == 1)
    assert rows[0]['phase'] == 'start' and rows[-1]['phase'] == 'grip_a'
    assert int(rows[-1]['step']) == 11
    assert float(rows[-1]['a_z']) == pytest.approx(0.8, abs=1e-6)
    L = np.array([[float(r[f'L{i}']) for i in range(1, 7)] for r in rows])
    assert L.min() >= 0.30 and L.max() <= 0.55  # the pole climber's stroke


@pytest.mark.parametrize('robot,structure', [('pole_climber', 'palm_trunk'), ('frame_climber', 'frame'),
                                             ('facade_climber', 'facade')])
def test_other_structures_plan(tmp_path, capsys, robot, structure):
    out = tmp_path / 'plan.csv'
    assert main(['--robot', robot, '--structure', structure, '--distance', '3.0', '--csv', str(out)]) == 0
    rows = _rows(out)
    margins = np.array([[float(r[f'margin_{k}']) for k in ('stroke', 'universal', 'spherical',
                                                           'interference', 'conditioning')]
                        for r in rows])
    assert np.all(margins >= 0.0)
    assert f'wrote {len(rows)} rows' in capsys.readouterr().out


def test_frame_without_extra_dof_is_refused_for_interference(capsys):
    code = main(['--robot', 'frame_climber', '--structure', 'frame', '--distance', '2.0',
                 '--no-extra-dof'])
    assert code == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith('rrps-climb: refused: step ') and 'phase move_b' in err
    # The first violation is the intermediate actuators touching; the margins printed for that
    # pose show the other limits still hold there.
    assert re.search(r'pose \d+/\d+\): interference: leg_1 and leg_2 are 0\.0\d+ m apart < 2 \* radius '
                     r'0\.1000 m', err), err
    there = dict((k, float(v)) for k, v in re.findall(r'(\w+) (-?\d+\.\d+)', err.split('[margins there:')[1]))
    assert there['interference'] < 0.0
    assert all(there[k] > 0.0 for k in ('stroke', 'universal', 'spherical', 'conditioning'))


def test_frame_with_extra_dof_passes_the_junction(tmp_path, capsys):
    out = tmp_path / 'frame.csv'
    assert main(['--robot', 'frame_climber', '--structure', 'frame', '--distance', '2.0',
                 '--csv', str(out)]) == 0
    summary = capsys.readouterr().out
    assert re.search(r'extra DOF -?0 / 90 deg', summary), summary   # ring_b's gripper turned
    rows = _rows(out)
    assert max(float(r['b_z']) for r in rows) > 2.0          # ring_b went past the junction J
    for k in ('stroke', 'universal', 'spherical', 'interference', 'conditioning'):
        assert min(float(r[f'margin_{k}']) for r in rows) > 0.0, k
    assert min(float(r['margin_interference']) for r in rows) > 0.05


def test_too_long_step_is_refused(capsys):
    assert main(['--structure', 'pole', '--distance', '0.8', '--steps', '1']) == 1
    err = capsys.readouterr().err
    assert 'stroke' in err and 'leg_1' in err


def test_a_heavy_payload_is_refused_for_holding(capsys):
    assert main(['--structure', 'pole', '--distance', '0.5', '--payload-mass', '200']) == 1
    err = capsys.readouterr().err
    assert err.startswith('rrps-climb: refused: holding, ring_a, step 0 start (hand-over'), err
    there = dict((k, float(v)) for k, v in re.findall(r'(\w+) (-?\d+\.\d+)', err.split('[margins there:')[1]))
    assert there['holding'] < 0.0


def test_a_climb_prints_and_writes_its_load_figures(tmp_path, capsys):
    out = tmp_path / 'plan.csv'
    assert main(['--structure', 'pole', '--distance', '0.5', '--payload-mass', '40', '--payload-com', '0.1,0,0',
                 '--structure-quaternion', '0.25881905,0,0,0.96592583', '--speed', '0.03',
                 '--csv', str(out)]) == 0
    summary = capsys.readouterr().out
    found = re.search(r'loads \(payload 40\.0 kg on ring_b\): peak actuator force (\d+\.\d) N \(leg_\d; '
                      r'limit 2000 N\), smallest holding margin (\d\.\d+) \(ring_[ab]\)', summary)
    assert found, summary
    rows = _rows(out)
    peaks = [float(r['peak_force']) for r in rows if r['peak_force'] != 'nan']
    margins = [float(r['holding_margin']) for r in rows if r['holding_margin'] != 'nan']
    assert max(peaks) == pytest.approx(float(found[1]), abs=0.05)
    assert min(margins) == pytest.approx(float(found[2]), abs=1e-3)
    # every phase has its duration: the motions their timing's, the grippers their switch times
    durations = [float(r['duration']) for r in rows]
    found = re.search(r'timing: (\d+\.\d) s in all, per step .*; climbing speed (\d+\.\d+) m/min', summary)
    assert found, summary
    assert sum(durations) == pytest.approx(float(found[1]), abs=0.05)
    assert all(float(r['duration']) in (0.5, 0.8) for r in rows if r['phase'].startswith(('release', 'grip')))
    steps = sum(float(r['duration']) for r in rows if int(r['step']) >= 1)
    climbed = float(rows[-1]['s_a']) - float(rows[0]['s_a'])
    assert float(found[2]) == pytest.approx(60.0 * climbed / steps, abs=0.01)


def test_a_speed_beyond_the_legs_is_capped_and_said_so(capsys):
    assert main(['--structure', 'pole', '--distance', '0.5', '--speed', '2']) == 0
    out = capsys.readouterr().out
    assert 'speed: 2 m/s requested, capped to what the legs allow' in out
    assert main(['--structure', 'pole', '--distance', '0.5', '--speed', '0.01']) == 0   # slower: no cap
    assert 'capped' not in capsys.readouterr().out


@pytest.mark.parametrize('speed', ['0', '-1', 'nan'])
def test_a_speed_that_is_not_positive_is_refused_naming_the_limit_step_and_phase(capsys, speed):
    assert main(['--structure', 'pole', '--distance', '0.5', '--speed', speed]) == 1
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and err.startswith('rrps-climb: refused: speed: ') and 'step 0 release_b' in err


@pytest.mark.parametrize('argv,needle', [
    (['--structure', 'tower', '--distance', '1'], 'invalid choice'),
    (['--structure', 'pole', '--distance', '0.5', '--payload-com', '0.1,0,0'], 'need --payload-mass'),
    (['--structure', 'pole', '--distance', '0.5', '--payload-mass', '-3'], 'payload.mass'),
    (['--structure', 'pole', '--distance', '0.5', '--structure-quaternion', '0,0,0,2'], '--structure-quaternion'),
    (['--structure', 'pole', '--distance', '0.5', '--gravity', '-9.81,0'], 'expected 3 numbers'),
    (['--structure', 'pole', '--distance', 'abc'], 'expected a number'),
    (['--structure', 'pole', '--distance', '0'], 'non-zero'),
    (['--structure', 'pole', '--distance', '1', '--steps', '0'], 'must be >= 1'),
    (['--structure', 'pole', '--distance', '-1'], 'leaves the pole'),
    (['--robot', 'no_such_robot', '--structure', 'pole', '--distance', '1'], 'unknown robot'),
    (['--structure', 'pole'], 'required'),
    (['--structure', 'pole', '--junction-deg', '90'], 'needs --structure frame'),
    (['--structure', 'frame', '--junction-deg', '120'], '1 .. 90 deg'),
    (['--structure', 'frame', '--junction-deg', '60', '--distance', '1'], 'leave out --distance'),
    (['--structure', 'frame', '--distance', '1', '--out-of-plane'], 'needs --junction-deg'),
])
def test_bad_arguments_exit_2_with_one_line(capsys, argv, needle):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and needle in err


def test_frame_node_crossing_prints_its_phases_and_margins(tmp_path, capsys):
    out = tmp_path / 'node.csv'
    assert main(['--robot', 'frame_climber', '--structure', 'frame', '--junction-deg', '90',
                 '--out-of-plane', '--csv', str(out)]) == 0
    text = capsys.readouterr().out
    assert '90 deg node out of plane, with the extra DOF' in text and 'candidates searched' in text
    assert re.search(r'move_b .* leg_\d +\d\.\d{3}', text) and re.search(r'move_a .* leg_\d', text)
    rows = _rows(out)
    assert [r['phase'] for r in rows] == ['start', 'release_b', 'move_b', 'grip_b', 'release_a', 'move_a', 'grip_a']
    assert abs(float(rows[-1]['theta_b'])) == pytest.approx(np.pi / 2)


def test_frame_node_without_extra_dof_is_refused_naming_limit_and_phase(capsys):
    assert main(['--robot', 'frame_climber', '--structure', 'frame', '--junction-deg', '90',
                 '--no-extra-dof']) == 1
    err = capsys.readouterr().err
    assert 'refused' in err and 'phase move_b' in err and 'blocks the closest' in err


def test_console_script(tmp_path):
    out = tmp_path / 'p.csv'
    proc = subprocess.run([sys.executable, '-m', 'rrps_climbing.cli', '--structure', 'pole',
                           '--distance', '0.3', '--csv', str(out)], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert out.exists() and 'ring_a climbed 0.300 m' in proc.stdout
