"""The project's exception types. Library code raises these; only CLIs turn them into exit codes."""


class SvbrdfError(Exception):
    """Base class of every error the project raises on purpose (bad input, bad model, ...).

    The message is one line, meant to be shown to a user as is.
    """


class ImageError(SvbrdfError):
    """An image file could not be read or written (missing, unreadable, unsupported, empty, NaN/Inf)."""


class ModelError(SvbrdfError):
    """A model file is missing, corrupt, or does not match its manifest."""
