"""The test's side of an agent process (:mod:`rrps_testing.netns_agent`, on a rig's host): the
records it prints as JSON lines, by topic and receipt time, and the commands it answers."""

from __future__ import annotations

import itertools
import json
import subprocess
import threading

from rrps_testing.netns import wait

__all__ = ['AgentHandle']


class AgentHandle:
    """The test's side of a rrps_testing.netns_agent process: its records (by topic) and commands."""

    def __init__(self, name: str, process: subprocess.Popen):
        self.name = name
        self.process = process
        self._lock = threading.Lock()
        self._records: dict[str, list[dict]] = {}
        self._replies: dict[int, dict] = {}
        self._ids = itertools.count(1)
        self.ready = threading.Event()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue
            if 'ready' in record:
                self.ready.set()
            elif 'reply' in record:
                with self._lock:
                    self._replies[record['reply']] = record
            elif 'topic' in record:
                with self._lock:
                    self._records.setdefault(record['topic'], []).append(record)

    def records(self, topic: str, start: float = -float('inf'), end: float = float('inf'),
                *, by: str = 't') -> list[dict]:
        """The records of ``topic`` whose receipt time (or ``by='stamp'``) lies in [start, end]."""
        with self._lock:
            rows = list(self._records.get(topic, ()))
        return [r for r in rows if start <= r.get(by, -float('inf')) <= end]

    def last(self, topic: str) -> dict | None:
        with self._lock:
            rows = self._records.get(topic)
            return rows[-1] if rows else None

    def send(self, command: dict, timeout: float = 30.0) -> dict:
        """Run a command (netns_agent.py's docstring) and return its reply."""
        ident = next(self._ids)
        self.process.stdin.write(json.dumps({**command, 'id': ident}) + '\n')
        self.process.stdin.flush()
        if not wait(lambda: ident in self._replies, timeout, period=0.01):
            raise TimeoutError(f'agent {self.name}: no reply to {command} in {timeout} s')
        with self._lock:
            return self._replies.pop(ident)

    def call(self, service: str, timeout: float = 30.0) -> dict:
        return self.send({'call': service, 'timeout': timeout}, timeout + 5.0)
