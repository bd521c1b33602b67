"""Suggestions for misspelt names, shared by every layer that reports one."""

from __future__ import annotations

from collections.abc import Iterable


def did_you_mean(word: str, candidates: Iterable[str]) -> str:
    """``' (did you mean "X"?)'`` for the candidate closest to ``word``, or ``''``.

    A case-only difference always matches (``actor`` for ``Actor``); otherwise the candidate
    must be similar enough that the suggestion is more likely help than noise.
    """
    # Imported here: a daemon loads this module for its error messages but rarely makes
    # one, and difflib is half a megabyte of its memory.
    import difflib

    pool = list(dict.fromkeys(candidates))
    for candidate in pool:
        if candidate.lower() == word.lower() and candidate != word:
            return f' (did you mean "{candidate}"?)'
    lowered = {c.lower(): c for c in pool}
    close = difflib.get_close_matches(word.lower(), list(lowered), n=1, cutoff=0.6)
    return f' (did you mean "{lowered[close[0]]}"?)' if close else ""
