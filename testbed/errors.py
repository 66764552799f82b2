"""The one error type for bad user input (scenario fields, CLI options)."""


class InputError(Exception):
    """Bad input: names the offending field and why; the CLI prints it on one line, exit 2."""

    def __init__(self, field: str, reason: str):
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")
