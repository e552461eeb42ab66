"""The one error type the CLI turns into a one-line message and exit code 2."""


class SvhdescError(Exception):
    """Bad input: the message names the culprit (file:line where known)."""
