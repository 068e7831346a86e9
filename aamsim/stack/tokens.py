"""Argument tokenizer of the scenario language.

Arguments are separated by white space and/or one comma; an empty field
between two commas (``,,``) is an empty token meaning "use the default";
double or single quotes group words into one token.
"""

from __future__ import annotations

_WS = " \t\r\n\f\v"


def next_arg(text: str) -> tuple[str, str]:
    """Split the first argument off ``text``.

    Returns:
        ``(token, rest)``; ``token`` is ``""`` for an empty field, ``rest``
        starts at the next argument.
    """
    i = 0
    n = len(text)
    while i < n and text[i] in _WS:
        i += 1
    if i < n and text[i] in "'\"":
        quote_end = i + 1
        while quote_end < n and text[quote_end] not in "'\"":
            quote_end += 1
        token = text[i + 1 : quote_end]
        i = min(quote_end + 1, n)
    else:
        start = i
        while i < n and text[i] not in _WS and text[i] != ",":
            i += 1
        token = text[start:i]
    while i < n and text[i] in _WS:
        i += 1
    if i < n and text[i] == ",":
        i += 1
    while i < n and text[i] in _WS:
        i += 1
    return token, text[i:]


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
