"""snakeplan: motion planning for hyper-redundant snake-arm robots.

Lengths are millimetres, angles radians, time seconds. Layers, lowest first (docs/ARCHITECTURE.md):
geometry -> robots -> ftl -> scenes -> world -> evaluation -> mapping -> planners -> episode -> rl -> viz -> bench
-> cli, over a base of utilities (registry, extras, jsonable, files) that import nothing of snakeplan.
"""

__version__ = "0.1.0"
