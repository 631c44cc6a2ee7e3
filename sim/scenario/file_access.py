"""Where a scenario's files come from: the disk, or texts handed over with the scenario.

Loading a scenario reads several files: the TOML file and its includes, the ``.mech`` file, the
torque-converter table, the compressor and turbine maps. :class:`FileAccess` reads them all, so
that a scenario can be built from texts instead of the disk (a sweep worker on another machine
gets the texts, not paths) and so that the files a scenario reads can be collected
(:func:`transgen.sim.scenario_files`). Files are keyed by their absolute resolved path
(``str(Path(p).resolve())``); a file not among the given texts is read from the disk.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from transgen.outputs import note_input

__all__ = ["FileAccess", "file_key"]


def file_key(path: str | Path) -> str:
    """The key of a file in :class:`FileAccess` texts: its absolute resolved path."""
    return str(Path(path).resolve())


class FileAccess:
    """Reads files from ``texts`` (key -> text, see :func:`file_key`) first, else from the disk,
    and remembers every text it gave out in :attr:`read` (key -> text)."""

    def __init__(self, texts: Mapping[str, str] | None = None):
        self.texts = dict(texts or {})
        self.read: dict[str, str] = {}

    def _key(self, path: Path) -> str | None:
        try:
            return file_key(path)
        except (OSError, ValueError, RuntimeError):
            return None

    def is_file(self, path: str | Path) -> bool:
        """Whether ``path`` is a given text or a file on the disk (False, not an error, for a
        name the system refuses)."""
        key = self._key(Path(path))
        if key is not None and key in self.texts:
            return True
        try:
            return Path(path).is_file()
        except (OSError, ValueError):
            return False

    def read_text(self, path: str | Path) -> str:
        """The text of ``path``; raises ``OSError`` or ``UnicodeDecodeError`` as reading the disk does."""
        key = self._key(Path(path))
        text = self.texts.get(key) if key is not None else None
        if text is None:
            text = Path(path).read_text(encoding="utf-8")
            note_input(path)  # an output of the running command must not overwrite it
        if key is not None:
            self.read[key] = text
        return text
