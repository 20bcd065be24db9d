"""The base of every error that bad input causes.

An option, a scenario, a data, model or artefact file, or an output path the user gave can be
wrong; the error raised then derives from :class:`BadInputError` (as well as from the built-in
error it is), so the ``tt-drake`` command reports every one of them the same way (one line on
stderr, exit status 2, no traceback) without importing the modules that raise them.
"""


class BadInputError(Exception):
    """Input the user gave cannot be used; the message names the problem."""
