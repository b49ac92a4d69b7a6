"""`hand-tracker params NODE`: print a node's default ``ros__parameters`` YAML.

The shipped ``config/<node>.yaml`` files are this command's output, so they always list every
parameter the node declares (a test checks it).
"""
from __future__ import annotations

import argparse
from typing import Any

import yaml

from hand_tracker_ros import node_config
from hand_tracker_ros.config import flatten

NODE_CONFIGS = node_config.NODE_CONFIGS


def default_parameters_yaml(node: str) -> str:
    """The YAML text of ``node``'s defaults (nested sections for dotted names)."""
    tree: dict[str, Any] = {}
    for name, value in flatten(NODE_CONFIGS[node]()).items():
        *parents, leaf = name.split('.')
        branch = tree
        for part in parents:
            branch = branch.setdefault(part, {})
        branch[leaf] = list(value) if isinstance(value, tuple) else value
    header = f'# ros__parameters of the `{node}` node (generated: hand-tracker params {node}).\n'
    return header + yaml.safe_dump({node: {'ros__parameters': tree}}, sort_keys=False)


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('params', help="print a node's default parameter file",
                            description=__doc__)
    parser.add_argument('node', choices=sorted(NODE_CONFIGS))
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Print the YAML."""
    print(default_parameters_yaml(args.node), end='')
    return 0
