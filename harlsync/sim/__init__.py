"""The simulator framework: serving a family's simulated controller over a pty,
TCP and ``sim://``, mode control, battery-backed memory, and replay of captures.

A family's simulated device lives in its own package (``harlsync.families.<name>.sim``).
"""
