"""Command-line plumbing shared by the rrps commands: one-line usage errors (exit status 2),
comma-separated vectors, negative vectors that argparse would take for flags, and the exit
status of a command's outcome (:func:`run_command`)."""

from __future__ import annotations

import argparse
import re
import sys
import traceback
from typing import Any, Callable, Sequence

import numpy as np

from rrps_description.geometry import RobotDescriptionError, RobotGeometry, load_robot
from rrps_kinematics.errors import ComputationError

__all__ = ['UsageError', 'OneLineParser', 'vector', 'positive', 'count', 'join_negative_vectors',
           'load_robot_or_usage_error', 'checked', 'format_vector', 'run_command', 'EXIT_OK',
           'EXIT_FAILED', 'EXIT_USAGE', 'EXIT_BUG']

#: Exit statuses of :func:`run_command`.
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_BUG = 0, 1, 2, 3


class UsageError(Exception):
    """A bad command line or input file: reported on one line, exit status 2."""


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors raise UsageError instead of printing usage and exiting."""

    def error(self, message: str):
        raise UsageError(message)


def vector(n: int):
    """argparse type: ``n`` finite comma-separated numbers -> ndarray (n,)."""
    def parse(text: str) -> np.ndarray:
        try:
            values = np.array([float(v) for v in text.split(',')])
        except ValueError:
            raise argparse.ArgumentTypeError(f'expected {n} comma-separated numbers, got {text!r}')
        if values.shape != (n,):
            raise argparse.ArgumentTypeError(f'expected {n} numbers, got {values.size}')
        if not np.all(np.isfinite(values)):
            raise argparse.ArgumentTypeError(f'values must be finite, got {text!r}')
        return values
    return parse


def positive(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected a number, got {text!r}')
    if not (np.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f'must be a positive number, got {text!r}')
    return value


def count(text: str) -> int:
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected an integer, got {text!r}')
    if value < 1:
        raise argparse.ArgumentTypeError(f'must be >= 1, got {value}')
    return value


def join_negative_vectors(argv: Sequence[str], options: Sequence[str]) -> list[str]:
    """``--position -0.1,0,0.4`` -> ``--position=-0.1,0,0.4`` for the given vector options."""
    out: list[str] = []
    args = list(argv)
    i = 0
    while i < len(args):
        if args[i] in options and i + 1 < len(args) and re.match(r'^-[\d.]', args[i + 1]):
            out.append(f'{args[i]}={args[i + 1]}')
            i += 2
        else:
            out.append(args[i])
            i += 1
    return out


def load_robot_or_usage_error(robot: str) -> RobotGeometry:
    """load_robot, with a bad name or file reported as a usage error."""
    try:
        return load_robot(robot)
    except RobotDescriptionError as exc:
        raise UsageError(str(exc)) from None


def checked(what: str, check, *args, **kwargs):
    """Validate a command-line input with the core's own check: its ValueError is a usage error."""
    try:
        return check(*args, **kwargs)
    except ComputationError:
        raise
    except ValueError as exc:
        raise UsageError(f'{what}: {exc}') from None



def format_vector(v: Any, digits: int = 6) -> str:
    """'[a, b, ...]' with ``digits`` decimals: a vector in a command's text output."""
    return '[' + ', '.join(f'{x:.{digits}f}' for x in np.ravel(v)) + ']'


def run_command(prog: str, body: Callable[[], Sequence[str]]) -> int:
    """Run a command's ``body``, print its lines and return the exit status: ``EXIT_OK`` (0),
    ``EXIT_USAGE`` (2: a :class:`UsageError`, one line on stderr), ``EXIT_FAILED`` (1: a
    :class:`~rrps_kinematics.errors.ComputationError`, one line) or ``EXIT_BUG`` (3: the traceback)."""
    try:
        lines = body()
    except UsageError as exc:
        print(f'{prog}: error: {exc}', file=sys.stderr)
        return EXIT_USAGE
    except ComputationError as exc:
        print(f'{prog}: error: {exc}', file=sys.stderr)
        return EXIT_FAILED
    except Exception:  # noqa: BLE001 - a bug: shown in full, never as a usage error
        traceback.print_exc()
        print(f'{prog}: internal error (a bug; the traceback above says where)', file=sys.stderr)
        return EXIT_BUG
    print('\n'.join(lines))
    return EXIT_OK
