"""The ``snakeplan`` command's subcommands: one module per command (or group of ``bench`` benchmarks), each with
its argparse sub-parser (``add_parser``) built beside its handler (``cmd_*``, returning the exit status).

Commands parse, call the layer that owns the work and print; the rules of the work live in that layer. Shared
here: :mod:`.common` (exit statuses, the one-line usage error, argument types, printing), :mod:`.inputs` (scene,
robot, path and planner from the options), :mod:`.options` (option groups several commands take) and
:mod:`.views` (pictures, videos and pages of a crawl). :mod:`snakeplan.cli` assembles the parser from these
modules and turns errors into exit statuses; nothing here imports it.
"""
