"""The declarations a family makes for the command line and the line lock:
its options (:class:`Option`), URL schemes (:class:`Scheme`), ``--help``
phrases (:class:`Help`) and interlock words (:class:`Words`).

Plain frozen records, read by the CLI and the link; :mod:`harlsync.families.base`
re-exports them so a family imports them from there as before.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Help", "Option", "Scheme", "Words"]


@dataclass(frozen=True)
class Option:
    """A command-line option of the family's connection: ``--reset-function``.

    Every command that opens a line offers it; :meth:`Family.connect` gets it as
    the keyword ``name`` (given only when set), and a robot of another family
    refuses it before anything is opened.
    """

    #: as :meth:`Family.connect` takes it: ``reset_function``
    name: str
    #: the ``--help`` text, which says which family it is for
    help: str

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")


@dataclass(frozen=True)
class Scheme:
    """A URL scheme of the family's own (``scheme://HOST[:PORT]``): the line lock
    takes such a URL as the TCP endpoint it names, with ``default_port`` when it
    names none, so one controller is one line whatever speaks to it."""

    name: str
    default_port: int
    #: how ``--port`` help shows it: ``a controller's TCP server: scheme://HOST[:PORT]``
    help: str


@dataclass(frozen=True)
class Help:
    """What ``harlsync --help`` says of the family, a phrase per place (empty: nothing
    to add there).  The command line shows each as ``<name>: <phrase>``."""

    #: ``--station``: ``1-99, as set on the pendant``
    stations: str = ""
    #: a list of stations as ``probe --stations`` takes it: ``1-4``
    station_list: str = ""
    #: what a pull reads: ``the settings and the tables``
    pull: str = ""
    #: the items a diff compares (and ``sim --seed`` generates): ``setting, table entry``
    items: str = ""
    #: one item as status and backup name it (``adopt ITEM``), quoted: ``'table 3'``
    item: str = ""
    #: what tells a robot from another (a pull refuses another until ``--new-robot``):
    #: ``version, model``
    identity: str = ""
    #: runtime data (``--registers``): ``registers``, ``flags and variables``
    runtime: str = ""
    #: the commands a plan prints, in the manual's words
    commands: str = ""
    #: the safe order of a push: ``configuration, parameters, tables``
    order: str = ""
    #: what stops a push: ``a program running, manual mode, emergency stop``
    busy: str = ""
    #: what ``--allow-live-tuning`` writes while the robot runs
    live_tuning: str = ""
    #: the write of a configuration change that destroys the programs
    #: (``--allow-reconfigure``), in the manual's words
    reconfigure: str = ""


@dataclass(frozen=True)
class Words:
    """The family's words for its interlock, in the engine's messages."""

    #: what the interlock reads: ``the robot's status``, ``the task states``
    state: str = "the robot's state"
