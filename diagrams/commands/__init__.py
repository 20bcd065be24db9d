"""The ``tt-drake`` commands, one module each.

A command module has ``register(subparsers)``, which adds the command's subparser with its
options and sets ``run``, the function that turns the parsed arguments into builder calls and
prints the outcome. Options several commands take are defined once in :mod:`.options`.
"""
