"""Errors that the command-line tools report as one line and exit code 2."""


class UserError(Exception):
    """Bad input from the user: a file, an option, a spec.  The message says
    what is wrong and where (file, line, column where it applies)."""


class DataError(UserError, ValueError):
    """A measured-data file that cannot be used."""
