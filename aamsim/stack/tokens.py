"""Argument tokenizer of the scenario language.

Arguments are separated by white space and/or one comma; an empty field
between two commas (``,,``) is an empty token meaning "use the default";
double or single quotes group words into one token.
"""

from __future__ import annotations

import re

# One argument and the separator after it, in one compiled match (a scenario of 1,000 flights has some
# 40,000 arguments; this takes about half the time of the character loop it replaces): white space; then
# a quoted token (up to the next quote of either kind, or the end) or a run of neither white space nor
# comma; then white space, at most one comma, white space. White space is these six characters only
# (Python's ``\s`` would also take a no-break space, which is part of a token).
_ARG = re.compile(r"[ \t\r\n\f\v]*(?:['\"]([^'\"]*)['\"]?|([^ \t\r\n\f\v,]*))[ \t\r\n\f\v]*,?[ \t\r\n\f\v]*")


def next_arg(text: str) -> tuple[str, str]:
    """Split the first argument off ``text``.

    Returns:
        ``(token, rest)``; ``token`` is ``""`` for an empty field, ``rest``
        starts at the next argument.
    """
    m = _ARG.match(text)
    assert m is not None  # every part of the pattern may be empty: it matches any text
    quoted = m.group(1)
    return (m.group(2) if quoted is None else quoted), text[m.end():]


def split_args(text: str) -> list[str]:
    """All tokens of an argument string (empty tokens kept)."""
    tokens: list[str] = []
    rest = text.strip()
    while rest:
        token, new_rest = next_arg(rest)
        tokens.append(token)
        if new_rest == rest:  # defensive: no progress
            break
        rest = new_rest
    return tokens
