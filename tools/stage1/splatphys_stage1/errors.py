"""The package's one exception type."""


class Stage1Error(Exception):
    """A user-facing error: bad input, a missing file or model, inconsistent outputs.

    The message names the file (or phrase, or option) and what was wrong; the CLI prints it
    and exits with status 2.
    """
