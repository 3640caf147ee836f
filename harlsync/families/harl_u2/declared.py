"""What the HARL-U2 family declares of its projects without its layout: the
stations robot.yaml allows and the folder of the programs.

:mod:`.family` needs them at import (``--help``, ``--station``), :mod:`.layout`
reads and writes the files by them; both take them from here.
"""

from __future__ import annotations

__all__ = ["FIRST_STATION", "LAST_STATION", "PROGRAMS_DIR", "STATION_ALLOWED"]

#: The stations robot.yaml's schema allows (``connection.station``), as its
#: ``x-allowed`` says them: --station is checked against the same.
FIRST_STATION, LAST_STATION = 1, 99
STATION_ALLOWED = f"{FIRST_STATION}-{LAST_STATION}"

#: The folder of a project that holds one file a program.
PROGRAMS_DIR = "programs"
