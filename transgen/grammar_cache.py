"""The LALR tables of a lark grammar, built once per user and grammar version.

Building the parser of ``mech.lark`` (the LALR analysis) takes about a third of the start-up
time of a numeric command; loading the saved tables takes a few milliseconds. The tables are
kept in the user's cache directory (``$XDG_CACHE_HOME/transgen``, default ``~/.cache/transgen``;
never a shared temporary folder, since lark saves them with ``pickle``), in a file named by the
SHA-256 of the grammar text, the parser options, and the lark and Python versions: a changed
grammar or an upgraded lark builds new tables. A file is written under a temporary name and
renamed into place, so a parallel run never reads half a file; a cache that cannot be read or
written (read-only home) only costs the build. ``TRANSGEN_NO_GRAMMAR_CACHE=1`` switches it off.
"""
from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

import lark
from lark import Lark

__all__ = ["cached_lark", "cache_dir"]


def cache_dir() -> Path:
    """The folder of the saved parser tables."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "transgen"


def _cache_file(text: str, options: dict) -> Path:
    key = repr((text, sorted(options.items()), lark.__version__, sys.version_info[:2]))
    return cache_dir() / f"lark-{hashlib.sha256(key.encode('utf-8')).hexdigest()[:32]}.pickle"


def cached_lark(text: str, **options) -> Lark:
    """``Lark(text, **options)``, loaded from the user's cache when it holds these tables."""
    if os.environ.get("TRANSGEN_NO_GRAMMAR_CACHE"):
        return Lark(text, **options)
    path = _cache_file(text, options)
    try:
        with open(path, "rb") as f:
            return Lark.load(f)
    except Exception:  # noqa: BLE001 - missing, truncated or from another lark: rebuild it
        pass
    parser = Lark(text, **options)
    import tempfile  # only to write the tables (its import costs start-up time)

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                parser.save(f)
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError:
        pass
    return parser
