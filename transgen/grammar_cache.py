"""The parser of a lark grammar as a generated module, built once per user and grammar version.

Importing lark and loading the LALR tables of ``mech.lark`` took a numeric command about a sixth
of its start-up (lark's own import pulls in its grammar compiler, Earley parsers, tempfile,
hashlib, ...). lark's *standalone* tool writes the tables of one grammar, with the run-time part
of lark they need (lexer, LALR parser, ``Tree``, ``Token``, the ``Unexpected*`` exceptions), into
one Python module that does not import lark; importing it costs about a third of importing lark
and loading the tables. The parser it builds is lark's own code, so it parses, positions and
reports errors exactly as ``lark.Lark`` does with the same options (tests/test_startup.py checks).

:func:`parser_module` keeps that module in the user's cache directory (``$XDG_CACHE_HOME/transgen``,
default ``~/.cache/transgen``; never a shared temporary folder, since the file is code that is
run), named by a checksum of the grammar text, the parser options, the Python version and the
installed lark; the module also holds the grammar text and the options it was built from and is
used only when they are the current ones. A file is written under a temporary name and renamed
into place, so a parallel run never reads half a file; a file that cannot be loaded is rebuilt;
a cache that cannot be written (read-only home) only costs the build, about 0.3 s.
``TRANSGEN_NO_GRAMMAR_CACHE=1`` builds the module in memory each time and writes nothing.
"""
from __future__ import annotations

import importlib.util
import os
import sys
import zlib
from pathlib import Path
from types import ModuleType

__all__ = ["parser_module", "cache_dir"]


def cache_dir() -> Path:
    """The folder of the generated parsers."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "transgen"


def _installed_lark() -> str:
    """The installed lark, without importing it: its package file's path, size and modification
    time (an upgrade or a reinstall changes them)."""
    spec = importlib.util.find_spec("lark")
    if spec is None or not spec.origin:
        return "no lark"
    stat = os.stat(spec.origin)
    return f"{spec.origin}:{stat.st_size}:{stat.st_mtime_ns}"


def _source(text: str, options: dict) -> str:
    """The standalone parser module of the grammar ``text`` (lark's tool; imports lark)."""
    import io

    from lark import Lark
    from lark.tools.standalone import gen_standalone

    out = io.StringIO()
    gen_standalone(Lark(text, **options), out=out)
    return out.getvalue() + f"\nGRAMMAR = {text!r}\nOPTIONS = {options!r}\n"


def _module_name(path: Path) -> str:
    return f"_transgen_{path.stem.replace('-', '_')}"  # not in the package: a file of the user's cache


def _execute(source: str, name: str, filename: str) -> ModuleType:
    module = ModuleType(name)
    module.__file__ = filename
    sys.modules[name] = module  # its dataclasses look their module up
    try:
        exec(compile(source, filename, "exec"), module.__dict__)  # noqa: S102 - lark's own generated code
    except BaseException:
        del sys.modules[name]
        raise
    return module


def _load(path: Path, text: str, options: dict) -> ModuleType | None:
    """The module saved in ``path`` if it is the parser of ``text`` with ``options``, else None."""
    if not path.is_file():
        return None
    name = _module_name(path)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)  # with its bytecode cached beside it, as any module's
        if getattr(module, "GRAMMAR", None) == text and getattr(module, "OPTIONS", None) == options:
            return module
    except Exception:  # noqa: BLE001 - truncated, or written by something else: rebuild it
        pass
    del sys.modules[name]
    return None


def parser_module(text: str, **options) -> ModuleType:
    """The generated module of the lark grammar ``text`` with the (LALR) ``options``: its
    ``Lark_StandAlone()`` builds the parser; ``Tree``, ``Token`` and ``UnexpectedInput`` (with
    ``UnexpectedCharacters``, ``UnexpectedToken``, ``UnexpectedEOF``) are the classes of what
    it returns and raises."""
    key = repr((text, sorted(options.items()), sys.version_info[:2], _installed_lark()))
    path = cache_dir() / f"parser-{zlib.crc32(key.encode('utf-8')):08x}.py"
    if os.environ.get("TRANSGEN_NO_GRAMMAR_CACHE"):
        return _execute(_source(text, options), _module_name(path), f"<parser of {path.stem}>")
    module = _load(path, text, options)
    if module is not None:
        return module
    source = _source(text, options)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        import tempfile  # only to write the module (its import costs start-up time)

        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp")
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(source)
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError:
        pass
    return _execute(source, _module_name(path), str(path))
