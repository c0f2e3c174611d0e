"""The project's own exceptions: each carries a one-line message meant for the user."""


class AdaptskyError(Exception):
    """Base class: the CLI prints ``str(error)`` on one line and exits with code 1."""


class ScenarioError(AdaptskyError):
    """A scenario file is missing, not TOML, or fails validation.

    ``lines`` holds one ``file: field.path: message`` line per problem found.
    """

    def __init__(self, lines: list[str]) -> None:
        self.lines = lines
        super().__init__("\n".join(lines))


class PluginError(AdaptskyError):
    """A channel-model plugin is unknown, broken, or does not follow the contract."""


class ResourceError(ScenarioError):
    """A scenario needs more memory than this machine has (one line: needed vs available)."""


class NonFiniteError(AdaptskyError):
    """A training step produced a NaN or an infinity; the run stops before storing it."""
