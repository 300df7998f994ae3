"""Parameter files of the rrps nodes: ``config/<node>.yaml`` of rrps_bringup (docs/usage.md, "Parameters").

Installed to ``share/<package>/config``, read beside the package from a source checkout. :func:`config_file` gives a
file's path, :func:`parameter_overrides` its rclpy Parameters for a node created in-process.
"""

from __future__ import annotations

import sys
from pathlib import Path

from rrps_bringup.registry import registered_nodes

__all__ = ['config_file', 'params_file_arguments', 'parameter_overrides', 'main']



def config_file(node: str) -> Path:
    """The parameter file of ``node``: installed (share/rrps_bringup/config) or in the sources."""
    nodes = registered_nodes()
    if node not in nodes:
        raise ValueError(f'unknown node {node!r}; known: {", ".join(nodes)}')
    candidates = []
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
        try:
            candidates.append(Path(get_package_share_directory('rrps_bringup')) / 'config')
        except (PackageNotFoundError, OSError):  # not installed, or no AMENT_PREFIX_PATH
            pass
    except ImportError:
        pass
    candidates.append(Path(__file__).resolve().parent.parent / 'config')
    for folder in candidates:
        path = folder / f'{node}.yaml'
        if path.is_file():
            return path
    raise FileNotFoundError(f'no parameter file for {node} in {", ".join(map(str, candidates))}')


def params_file_arguments(*nodes: str) -> list[str]:
    """``--params-file <file>`` for each node (to put after ``--ros-args``)."""
    out: list[str] = []
    for node in nodes:
        out += ['--params-file', str(config_file(node))]
    return out


def parameter_overrides(node: str, path: str | Path | None = None) -> list:
    """The rclpy Parameters of ``node``'s section of its file (or of ``path``).

    Read with PyYAML here (rclpy's ``parameter_dict_from_yaml_file`` turns a float such as
    1e-12 into text and back, and gets a string)."""
    import yaml
    from rclpy.parameter import Parameter
    path = Path(path or config_file(node))
    data = yaml.safe_load(path.read_text(encoding='utf-8')) or {}
    section = data.get(f'/**/{node}')
    if not isinstance(section, dict) or not isinstance(section.get('ros__parameters'), dict):
        raise ValueError(f'{path}: no /**/{node}: ros__parameters: section')
    return [Parameter(name, value=list(value) if isinstance(value, (list, tuple)) else value)
            for name, value in section['ros__parameters'].items()]


SOURCE_CONFIG = Path(__file__).resolve().parent.parent / 'config'
#: The parameter reference of every node, generated from the schemas (rrps-params --write).
PARAMETERS_DOC = Path(__file__).resolve().parents[3] / 'docs' / 'parameters.md'


def generated_files() -> dict[Path, str]:
    """{path: text} of every node's parameter file and of docs/parameters.md, from the schemas."""
    files = {}
    doc = ['# Node parameters', '',
           'Every parameter of every rrps node, generated from the nodes\' parameter schemas',
           '(`rrps-params --write`; a test keeps this file and `rrps_bringup/config/*.yaml` equal to',
           'them). Parameters not settable at run time are read-only. A node that hosts a hardware',
           '(driver_node, master_node) declares its own parameters, then those of the hardware its',
           '`hardware` parameter names: each hardware\'s table follows the node\'s, and the node\'s',
           'parameter file holds its own and those of the default hardware.', '']
    for name, node in registered_nodes().items():
        schema = node.parameters()
        if schema is None:
            continue
        selector, hosted = node.hosted_parameters()
        files[SOURCE_CONFIG / f'{name}.yaml'] = _config_yaml(schema, node.declared_parameters(), selector, hosted)
        doc.append(schema.markdown())
        for implementation, owned in hosted.items():
            if owned.parameters:
                table = owned.markdown().split('\n', 1)[1]
                doc.append(f'#### {name} with `{selector}: {implementation}` ({owned.package})\n{table}')
    files[PARAMETERS_DOC] = '\n'.join(doc)
    return files


def _config_yaml(schema, declared, selector: str, hosted: dict) -> str:
    """A node's parameter file: its own parameters, then those of its default hardware, if any."""
    own = schema.config_yaml()
    if len(declared.parameters) == len(schema.parameters):
        return own
    default = schema[selector].default
    package = hosted[default].package
    note = (f'    # --- the parameters of {selector} {default} ({package}), the default; another {selector}\n'
            f'    # declares its own instead (docs/parameters.md) and these are not read\n')
    return own + note + declared.config_yaml()[len(own):]


def main(argv=None) -> int:
    """rrps-params NODE | --write | --check: a node's parameter file, or the generated files."""
    argv = list(sys.argv[1:] if argv is None else argv)
    usage = ('usage: rrps-params NODE       print the path of the node\'s parameter file\n'
             '       rrps-params --write    write config/*.yaml and docs/parameters.md from the schemas\n'
             '       rrps-params --check    exit 1 if a generated file differs from its schema\n'
             f'nodes: {", ".join(registered_nodes())}')
    if len(argv) != 1 or argv[0] in ('-h', '--help'):
        print(usage, file=sys.stdout if argv else sys.stderr)
        return 0 if argv else 2
    if argv[0] in ('--write', '--check'):
        stale = []
        for path, text in generated_files().items():
            if not path.exists() or path.read_text(encoding='utf-8') != text:
                stale.append(path)
                if argv[0] == '--write':
                    path.write_text(text, encoding='utf-8')
        for path in stale:
            print(f'{"written" if argv[0] == "--write" else "differs from its schema"}: {path}')
        return 1 if stale and argv[0] == '--check' else 0
    try:
        print(config_file(argv[0]))
    except (ValueError, FileNotFoundError) as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    return 0


if __name__ == '__main__':
    sys.exit(main())
