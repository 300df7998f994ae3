"""No import cycle anywhere in src/: the module graph, read from the source with ``ast``, is
acyclic.

Every ``import`` counts, at module level or inside a function (a lazy import still closes a
cycle once it runs). ``from package import name`` depends on the submodule ``package.name`` when
there is one, else on the package itself. A submodule's implicit import of its parent package is
not an edge: Python imports parents first, which cannot deadlock.
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / 'src'


def source_modules(src: Path = SRC) -> dict[str, Path]:
    """Dotted module name -> file for every Python package under src/<distribution>/<package>."""
    modules = {}
    for init in sorted(src.glob('*/*/__init__.py')):
        root = init.parent
        for path in sorted(root.rglob('*.py')):
            parts = (root.name,) + path.relative_to(root).with_suffix('').parts
            if parts[-1] == '__init__':
                parts = parts[:-1]
            modules['.'.join(parts)] = path
    return modules


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The modules of ``modules`` that module ``name`` (source ``path``) imports."""
    package = name.split('.') if path.name == '__init__.py' else name.split('.')[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                origin = '.'.join(base + ([node.module] if node.module else []))
            else:
                origin = node.module
            for alias in node.names:
                sub = f'{origin}.{alias.name}'
                found.add(sub if sub in modules else origin)
    return {m for m in found if m in modules and m != name}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the directed graph as a path [a, b, ..., a], or None if it is acyclic."""
    state: dict[str, int] = {}          # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                cycle = visit(nxt)
                if cycle:
                    return cycle
        path.pop()
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state:
            cycle = visit(start)
            if cycle:
                return cycle
    return None


def test_the_cycle_finder_finds_direct_lazy_and_long_cycles(tmp_path):
    assert find_cycle({'a': {'b'}, 'b': {'c'}, 'c': set()}) is None
    assert find_cycle({'a': {'b'}, 'b': {'c'}, 'c': {'a'}}) == ['a', 'b', 'c', 'a']
    pkg = tmp_path / 'dist' / 'pkg'
    pkg.mkdir(parents=True)
    (pkg / '__init__.py').write_text('from .one import f\n')
    (pkg / 'one.py').write_text('from . import two\n\ndef f():\n    return two\n')
    (pkg / 'two.py').write_text('def g():\n    from .one import f  # lazy, still a cycle\n')
    modules = source_modules(tmp_path)
    graph = {name: imports_of(name, path, modules) for name, path in modules.items()}
    assert graph == {'pkg': {'pkg.one'}, 'pkg.one': {'pkg.two'}, 'pkg.two': {'pkg.one'}}
    assert find_cycle(graph) == ['pkg.one', 'pkg.two', 'pkg.one']


def test_no_import_cycle_in_src():
    modules = source_modules()
    assert {'rrps_kinematics.backend', 'rrps_kinematics.compiled',
            'rrps_sim.dynamics'} <= set(modules)
    graph = {name: imports_of(name, path, modules) for name, path in modules.items()}
    assert graph['rrps_kinematics.forward'] >= {'rrps_kinematics.backend',
                                                'rrps_kinematics.inverse'}
    cycle = find_cycle(graph)
    assert cycle is None, 'import cycle: ' + ' -> '.join(cycle)


def _private_name_imports(root: Path) -> list[str]:
    """Every ``from M import _name`` (a private name of another module) under ``root``. A package
    may import its own private modules (``from . import _render``: a facade over them)."""
    found = []
    for path in sorted(root.rglob('*.py')):
        if 'build' in path.parts or 'install' in path.parts:
            continue
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.ImportFrom) and node.module is not None:
                for alias in node.names:
                    if alias.name.startswith('_') and not alias.name.startswith('__'):
                        found.append(f'{path.relative_to(root)}:{node.lineno}: '
                                     f'from {"." * node.level}{node.module or ""} import {alias.name}')
    return found


def test_no_module_imports_a_private_name_of_another():
    assert _private_name_imports(SRC) == []


def test_the_private_name_check_finds_one(tmp_path):
    (tmp_path / 'a.py').write_text('from .b import _hidden\nfrom .c import public, __version__\n'
                                   'from . import _private_module\n')
    assert _private_name_imports(tmp_path) == ['a.py:1: from .b import _hidden']
