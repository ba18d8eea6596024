"""Errors the CLI reports as one clear line (no traceback unless --verbose)."""


class ArstreamError(Exception):
    """A user-facing failure: bad input, missing file, unusable video.

    ``exit_code`` is what the CLI returns for it (2 for usage/input errors,
    1 for processing failures).
    """

    exit_code = 1

    def __init__(self, message: str, *, exit_code: int | None = None):
        super().__init__(message)
        if exit_code is not None:
            self.exit_code = exit_code


class InputError(ArstreamError):
    """The input (file, URL, parameters) cannot be used."""

    exit_code = 2


class SourceLost(ArstreamError):
    """A live network source stopped delivering (stalled or dropped) and did not
    come back within the reconnection window; raised by the source after the
    last frame it read, so the outputs hold every frame up to the loss.
    ``summary``: the run's summary when a pipeline ran (set by
    :func:`arstream.pipeline.stream`), else None."""

    exit_code = 1
    summary = None
