"""The project's exception types. Library code raises these; only CLIs turn them into exit codes."""


class SvbrdfError(Exception):
    """Base class of every error the project raises on purpose (bad input, bad model, ...).

    The message is one line, meant to be shown to a user as is.
    """


class ImageError(SvbrdfError):
    """An image file could not be read or written (missing, unreadable, unsupported, empty, NaN/Inf)."""


class MapError(SvbrdfError, ValueError):
    """A texture set given to the API is inconsistent: maps of different sizes, a wrong shape (also a
    ``ValueError``, as before it had its own type)."""


class ModelError(SvbrdfError):
    """A model file is missing, corrupt, or does not match its manifest."""


class MissingExtraError(SvbrdfError):
    """An optional part of the toolkit (the ``train`` extra: torch, kornia, onnx) is not installed; the message
    names the pip command (:func:`svbrdf.runtime.install.train_hint`). The commands exit 2 on it."""


#: How the API says an existing file is kept; :func:`cli_message` turns it into the command line's wording.
OVERWRITE_HINT = "pass force=True to overwrite"


def exists_message(path, more: int = 0) -> str:
    """``"<path>: exists (pass force=True to overwrite)"``, the one refusal to overwrite of every API writer."""
    return f"{path}: exists{f' (and {more} more)' if more else ''} ({OVERWRITE_HINT})"


def cli_message(exc) -> str:
    """An error's one-line message as a command prints it: the API's ``force=True`` becomes the flag ``--force``."""
    return str(exc).replace(OVERWRITE_HINT, "use --force to overwrite")


def parse_command_line(parser, argv=None):
    """Parse ``argv`` with an ``argparse.ArgumentParser`` the way every command of the project does.

    Returns:
        ``(args, None)`` on success, or ``(None, code)`` when argparse ended the command: 0 after ``--help`` or
        ``--version``, 2 after a usage error (already printed by argparse). A CLI's ``main`` returns the code.
    """
    try:
        return parser.parse_args(argv), None
    except SystemExit as exc:
        return None, int(exc.code or 0)
