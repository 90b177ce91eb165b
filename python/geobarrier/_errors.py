"""The exceptions geobarrier raises; the native module raises them for the core's errors (errors.hpp)."""


class Error(Exception):
    """A geobarrier error: the computation failed (a plugin, a numerical stage, a file)."""


class ConfigError(Error, ValueError):
    """Bad input in an experiment. ``str(e)`` is the program's message, "<where>: <what>"; ``e.path`` is the JSON
    path (e.g. "/grid/n/0"), or "file:line:col" for malformed JSON; ``e.file`` the experiment file the core named
    ("" for a dict, and for errors found after parsing, such as plugin parameters)."""

    def __init__(self, message, where=""):
        super().__init__(message)
        # The core prefixes the file to the JSON path of a file's structural errors: "exp.json: /grid/n".
        file, separator, path = where.rpartition(": /")
        self.file, self.path = (file, "/" + path) if separator else ("", where)


class PluginError(Error):
    """A plugin that cannot be loaded or that failed a call."""


class NumericalError(Error):
    """A numerical stage that cannot give a trustworthy answer (e.g. every grid point was masked)."""


class IoError(Error, OSError):
    """An input or output file that cannot be read or written."""
