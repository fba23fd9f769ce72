"""snakeplan: motion planning for hyper-redundant snake-arm robots.

Lengths are millimetres, angles radians, time seconds. Layers, lowest first (docs/ARCHITECTURE.md):
geometry -> robots -> ftl -> scenes -> world -> evaluation -> optimize -> trajectory -> mapping -> planners -> episode
-> rl -> viz -> bench -> cli, over a base of utilities (registry, extras, jsonable, files, inputs, interrupt,
checkpoints, threads, parallel, jit) that import nothing of snakeplan but each other.
"""

__version__ = "0.1.0"
