"""The alphabets of the values uam2scn writes into a scenario file.

A scenario line is a command; anything a schedule or network file puts into
one must stay a value of that command. Network and schedule files come from
other tools and other people, so every value that reaches the scenario text
is checked against a defined alphabet where it is read, and the row (or the
network key) is refused with its line when it does not fit:

- an aircraft type is 1 to :data:`AIRCRAFT_TYPE_MAX_CHARS` ASCII letters and
  digits (``EC35``, ``EVTOL4``): a ``;`` would chain a second command, a
  space or comma would shift every later argument;
- a callsign is built from the flight id (:func:`uamtoolkit_import.schedule.callsign_for`)
  and is at most :data:`CALLSIGN_MAX_CHARS` characters;
- a name (network, vertiport, corridor, kind) and a point id end up in comment
  lines: they hold no control character and no line or paragraph separator
  (``\\n`` or ``\\r`` would end the comment and start a command line), and
  have a bounded length.

Text that is not data (the schedule's path in the header) is escaped by
:func:`comment_text` instead.
"""

from __future__ import annotations

import re
import unicodedata

from aamsim.units import MAX_CALLSIGN_CHARS

AIRCRAFT_TYPE_MAX_CHARS = 16
CALLSIGN_MAX_CHARS = MAX_CALLSIGN_CHARS  # what CRE accepts
POINT_ID_MAX_CHARS = 64
NAME_MAX_CHARS = 200

_AIRCRAFT_TYPE = re.compile(rf"[A-Za-z0-9]{{1,{AIRCRAFT_TYPE_MAX_CHARS}}}")


def aircraft_type_problem(text: str) -> str | None:
    """Why ``text`` is not an aircraft type to write into a ``CRE`` line, or None when it is."""
    if _AIRCRAFT_TYPE.fullmatch(text):
        return None
    if len(text) > AIRCRAFT_TYPE_MAX_CHARS:
        return f"an aircraft type is at most {AIRCRAFT_TYPE_MAX_CHARS} letters and digits, not {len(text)} characters"
    return f"{_shown(text)} is not an aircraft type (ASCII letters and digits only)"


def _is_unsafe(ch: str) -> bool:
    """Control, format, surrogate, private-use or unassigned characters, and line/paragraph separators."""
    return unicodedata.category(ch)[0] == "C" or unicodedata.category(ch) in ("Zl", "Zp")


def text_problem(text: str, max_chars: int = NAME_MAX_CHARS) -> str | None:
    """Why ``text`` cannot be written into a scenario's comment line, or None when it can."""
    if len(text) > max_chars:
        return f"longer than {max_chars} characters ({len(text)})"
    bad = next((ch for ch in text if _is_unsafe(ch)), None)
    if bad is not None:
        return f"holds the control character U+{ord(bad):04X} (names are one line of printable text)"
    return None


def comment_text(text: str) -> str:
    """``text`` with every unsafe character escaped (``\\n`` -> ``\\x0a``): it stays one comment line."""
    return "".join(f"\\x{ord(ch):02x}" if _is_unsafe(ch) and ord(ch) < 256 else
                   f"\\u{ord(ch):04x}" if _is_unsafe(ch) else ch for ch in text)


def _shown(text: str, limit: int = 40) -> str:
    """``text`` quoted for a message: escaped and cut, so the message is one readable line."""
    shown = comment_text(text[:limit])
    return f'"{shown}"' + ("..." if len(text) > limit else "")
