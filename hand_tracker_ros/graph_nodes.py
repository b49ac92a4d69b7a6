"""The nodes of the graph, in one list (graph order: image consumers, tracker, bag I/O).

Each name is a node, its executable (``nodes/<name>_node.py``'s ``main``, see setup.py), its
``config/<name>.yaml`` and its config class (``node_config.NODE_CONFIGS``). setup.py, the ROS 2
launch file, ``hand-tracker launch``/``demo``/``params``, the tests and the README's node table
follow this list. It imports nothing, so setup.py can read it before the package is installed.
"""

NODES = ('features', 'salient_points', 'tracker', 'player', 'recorder')
