"""harlsync: keep Hirata HARL-U2 robot programs under version control."""

from .errors import HarlsyncError

__version__ = "0.1.0"
__all__ = ["HarlsyncError", "__version__"]
