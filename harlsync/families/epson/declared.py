"""What the Epson family declares without its profile: the Modbus TCP port and unit
id a robot file leaves out.  :mod:`.family` needs them at import (``--help``, the
line lock's scheme, a first pull), :mod:`.profile` says them with the rest of the
line; both take them from here, so that a command does not import the profile
before it opens a line (issue 24)."""

from __future__ import annotations

__all__ = ["DEFAULT_PORT", "DEFAULT_UNIT"]

#: Modbus TCP port when the URL gives none (``modbus://HOST[:PORT]``).
DEFAULT_PORT = 502
#: Modbus unit id when the robot file gives none.
DEFAULT_UNIT = 1
