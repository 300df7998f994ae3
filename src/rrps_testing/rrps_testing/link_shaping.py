"""A field link on a rig: bandwidth caps, random loss and outages on a veth pair, inside the rig's
network namespaces (root; this kernel has no netem).

Bandwidth: ``tc ... tbf`` on a host's end caps what that host sends, with a queue of ``latency`` s (a Wi-Fi
or LTE link queues); loss and outages: an nftables table ``rrps_link`` drops that share (or all) of what a
host receives on its end. :class:`LinkShaping` (a ``with`` block) undoes everything when it closes, also when
the test fails.
"""

from __future__ import annotations

import json
import subprocess

__all__ = ['LinkShaping', 'nft_available', 'veth_bytes']

TABLE = 'rrps_link'


def _run(namespace: str, *command: str, stdin: str | None = None, check: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run(['ip', 'netns', 'exec', namespace, *command], input=stdin, check=check,
                          capture_output=True, text=True, timeout=30)


def nft_available() -> tuple[bool, str]:
    """(True, '') when nftables' ``nft`` is installed."""
    import shutil
    if shutil.which('nft') is None:
        return False, 'nftables (nft) is not installed: apt-get install nftables'
    return True, ''


def veth_bytes(namespace: str, device: str) -> tuple[int, int]:
    """(tx, rx) bytes of ``device`` in ``namespace`` (``ip -s -j link``)."""
    out = subprocess.run(['ip', '-n', namespace, '-s', '-j', 'link', 'show', 'dev', device],
                         check=True, capture_output=True, text=True, timeout=30).stdout
    stats = json.loads(out)[0]['stats64']
    return int(stats['tx']['bytes']), int(stats['rx']['bytes'])


class LinkShaping:
    """Bandwidth, loss and outages of one veth pair (module docstring): ``robot``/``robot_dev``
    the robot host's namespace and end, ``operator``/``operator_dev`` the operator station's."""

    def __init__(self, robot: str, robot_dev: str, operator: str, operator_dev: str):
        self._ends = {'robot': (robot, robot_dev), 'operator': (operator, operator_dev)}
        self._shaped: set[str] = set()
        self._tables: set[str] = set()
        self.loss_share = 0.0
        self.down = False

    def __enter__(self) -> 'LinkShaping':
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def limit(self, *, robot_to_operator: float | None = None, operator_to_robot: float | None = None,
              latency: float = 0.2, burst: int = 8192) -> None:
        """Cap each direction at that many bit/s (None: no cap), queueing up to ``latency`` s."""
        for host, rate in (('robot', robot_to_operator), ('operator', operator_to_robot)):
            namespace, dev = self._ends[host]
            if host in self._shaped:
                _run(namespace, 'tc', 'qdisc', 'del', 'dev', dev, 'root', check=False)
                self._shaped.discard(host)
            if rate is None:
                continue
            if not rate > 0:
                raise ValueError(f'a bandwidth is > 0 bit/s, got {rate}')
            _run(namespace, 'tc', 'qdisc', 'add', 'dev', dev, 'root', 'tbf', 'rate', f'{int(rate)}bit',
                 'burst', str(int(burst)), 'latency', f'{int(latency * 1e3)}ms')
            self._shaped.add(host)

    def loss(self, share: float) -> None:
        """Drop ``share`` (0..1) of the packets each host receives on its veth end."""
        if not 0.0 <= share <= 1.0:
            raise ValueError(f'a loss share is in [0, 1], got {share}')
        self.loss_share = share
        self._apply()

    def outage(self, down: bool) -> None:
        """Drop every packet on the link (True) or go back to the set loss (False)."""
        self.down = down
        self._apply()

    def _apply(self) -> None:
        share = 1.0 if self.down else self.loss_share
        for host, (namespace, dev) in self._ends.items():
            if host in self._tables:
                _run(namespace, 'nft', 'delete', 'table', 'inet', TABLE, check=False)
                self._tables.discard(host)
            if share <= 0.0:
                continue
            rule = ('drop' if share >= 1.0 else
                    f'numgen random mod 10000 < {int(round(share * 10000))} counter drop')
            _run(namespace, 'nft', '-f', '-', stdin=(
                f'table inet {TABLE} {{\n  chain input {{\n'
                f'    type filter hook input priority 0; policy accept;\n'
                f'    iifname "{dev}" {rule}\n  }}\n}}\n'))
            self._tables.add(host)

    def close(self) -> None:
        """Undo every cap, loss and outage (what could not be undone goes with the namespace)."""
        self.down, self.loss_share = False, 0.0
        for host in list(self._tables):
            namespace, _ = self._ends[host]
            _run(namespace, 'nft', 'delete', 'table', 'inet', TABLE, check=False)
        self._tables.clear()
        for host in list(self._shaped):
            namespace, dev = self._ends[host]
            _run(namespace, 'tc', 'qdisc', 'del', 'dev', dev, 'root', check=False)
        self._shaped.clear()
