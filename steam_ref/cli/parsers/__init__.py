"""Each command's options, one module per command: ``add_parser(sub)`` adds the command and its options to the
subparsers and returns its parser (``SOLVES = False`` when it runs no solver).

These modules read only :mod:`steam_ref.choices`, the data sets' registry and :mod:`steam_ref.cli.args`: no
NumPy, no solver. The command itself, ``run(args)``, is in the module :data:`steam_ref.cli.commands.COMMANDS` pairs
with each, loaded once the arguments are parsed, so that ``steam-ref --help``, ``steam-ref COMMAND --help`` and a
bad argument's one-line answer cost about what ``steam-ref --version`` does.
"""
