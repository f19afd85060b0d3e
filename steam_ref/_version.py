"""The installed version, read from the package metadata (written once, in pyproject.toml)."""

from importlib import metadata as _metadata

try:
    __version__ = _metadata.version("steam_ref")
except _metadata.PackageNotFoundError:  # the source folder on sys.path, never installed
    __version__ = "0+unknown"

__all__ = ["__version__"]
