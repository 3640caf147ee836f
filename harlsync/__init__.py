"""harlsync: keep industrial robot programs and settings under version control."""

from . import families as _families  # noqa: F401  (the project store finds families through it)
from .errors import HarlsyncError

__version__ = "0.1.0"
__all__ = ["HarlsyncError", "__version__"]
