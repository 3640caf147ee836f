"""A test-only controller family: its own codec, simulator, catalogue, driver,
files and schema, registered from outside harlsync (no edit of harlsync)."""

from harlsync import families

families.register("toy", __name__)
