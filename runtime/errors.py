"""The project's exception types. Library code raises these; only CLIs turn them into exit codes."""


class SvbrdfError(Exception):
    """Base class of every error the project raises on purpose (bad input, bad model, ...).

    The message is one line, meant to be shown to a user as is.
    """


class ImageError(SvbrdfError):
    """An image file could not be read or written (missing, unreadable, unsupported, empty, NaN/Inf)."""


class ModelError(SvbrdfError):
    """A model file is missing, corrupt, or does not match its manifest."""


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
