"""Each family's simulator in a few words, for ``harlsync sim --help``: its control
commands, what busy means to it, the variants it can answer as."""

from __future__ import annotations

from .. import families
from .control import after_writes_verb
from .family import sim_family

__all__ = ["busy_words", "variants_words", "verbs_words"]


def verbs_words() -> str:
    """The control commands of each family's simulator: ``name: verb, ..., status; ...``."""
    lines = []
    for name in families.names():
        family = sim_family(name)
        verbs = [str(v) for v in family.verbs]
        verbs.append(f"{after_writes_verb(family.busy_verb)} N")
        lines.append(f"{name}: {', '.join(verbs)}, status")
    return "; ".join(lines)


def busy_words() -> str:
    """What each family's simulator does when it is made busy."""
    parts = []
    for name in families.names():
        family = sim_family(name)
        does = [v.does for v in family.verbs if v.name == family.busy_verb]
        parts.append(f"{name}: {does[0] if does else family.busy_verb}")
    return "; ".join(parts)


def variants_words() -> str:
    """Each family's simulator variants (the guesses it can make otherwise)."""
    parts = []
    for name in families.names():
        declared = sim_family(name).variants
        parts.append(f"{name}: {', '.join(str(v) for v in declared) or 'none'}")
    return "; ".join(parts)
