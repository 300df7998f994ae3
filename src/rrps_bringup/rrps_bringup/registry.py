"""The one registry of rrps nodes: the ``rrps.nodes`` entry-point group, declared by each package's setup.py
(``NODES``) and read by rrps-compose and rrps-params (docs/architecture.md, "How to add a node")."""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from importlib.metadata import entry_points

from rrps_runtime.parameter_schema import NodeParameters

__all__ = ['GROUP', 'RegisteredNode', 'registered_nodes', 'node_class']

GROUP = 'rrps.nodes'


@dataclass(frozen=True)
class RegisteredNode:
    """A node of the registry: its executable name, the package that ships it and its class path."""

    name: str
    package: str
    target: str  # 'module:Class'

    @property
    def module(self) -> str:
        return self.target.split(':')[0]

    def load(self):
        """The node class."""
        module, cls = self.target.split(':')
        return getattr(importlib.import_module(module), cls)

    def parameters(self):
        """The node's parameter schema (its module's ``PARAMETERS``, a NodeParameters), or None."""
        return getattr(importlib.import_module(self.module), 'PARAMETERS', None)

    def hosted_parameters(self) -> tuple[str, dict]:
        """For a node that hosts an implementation it names by a parameter (driver_node's
        ``hardware``): that parameter and {implementation: the parameters the node declares for
        it} (its module's ``HOSTED_BY`` and ``hosted_parameters()``); ('', {}) for the others."""
        module = importlib.import_module(self.module)
        hosted = getattr(module, 'hosted_parameters', None)
        return (module.HOSTED_BY, hosted()) if hosted is not None else ('', {})

    def declared_parameters(self):
        """Every parameter the node declares as it starts by default: its schema, then, for a
        node that hosts an implementation, those of the default one (None without a schema)."""
        schema = self.parameters()
        selector, hosted = self.hosted_parameters()
        owned = hosted.get(schema[selector].default) if schema is not None and selector else None
        return schema if owned is None else NodeParameters(schema.node, schema.package, [*schema, *owned])


def registered_nodes() -> dict[str, RegisteredNode]:
    """{name: node} of every installed rrps package, sorted by name."""
    found = {}
    for ep in entry_points(group=GROUP):
        package = ep.dist.name if ep.dist is not None else ep.value.split('.')[0]
        found[ep.name] = RegisteredNode(ep.name, package.replace('-', '_'), ep.value)
    return dict(sorted(found.items()))


def node_class(name: str):
    """The node class registered as ``name``; ValueError naming the known ones."""
    nodes = registered_nodes()
    if name not in nodes:
        raise ValueError(f'unknown node {name!r}; known: {", ".join(nodes)}')
    return nodes[name].load()
