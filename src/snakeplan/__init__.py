"""snakeplan: motion planning for hyper-redundant snake-arm robots.

Lengths are millimetres, angles radians, time seconds. Layers, lowest first:
geometry -> robots -> ftl -> scenes -> evaluation -> planners -> viz/bench -> cli.
"""

__version__ = "0.1.0"
