"""Where each key of a TOML text is: line and column, for located error messages.

``tomllib`` gives the values of a file but not their positions. :func:`key_positions` walks a text
that ``tomllib`` has already accepted and maps every key path to the place its key is written:
table names and keys as strings, array elements (and arrays of tables, counted in file order) as
integer indices, e.g. ``("elements", "C1", "apply", "value", 2)`` or ``("load", 0, "signal")``.
An array element's position is that of the element itself. Lines and columns count from 1.
"""
from __future__ import annotations

import re
from bisect import bisect_right

__all__ = ["key_positions"]

_BARE = re.compile(r"[A-Za-z0-9_-]+")
_SCALAR = re.compile(r"[^,\]}\n#]*")
_ESCAPES = {"b": "\b", "t": "\t", "n": "\n", "f": "\f", "r": "\r", '"': '"', "\\": "\\"}


class _Unexpected(Exception):
    """The text is not what the walker expects (it never is for a text tomllib accepted)."""


class _Walker:
    def __init__(self, text: str):
        self.s = text
        self.i = 0
        self.starts = [0] + [m.end() for m in re.finditer("\n", text)]
        self.found: dict[tuple, tuple[int, int]] = {}

    def where(self, i: int) -> tuple[int, int]:
        line = bisect_right(self.starts, i)
        return line, i - self.starts[line - 1] + 1

    def record(self, path: tuple, at: int) -> None:
        for k in range(1, len(path) + 1):
            self.found.setdefault(path[:k], self.where(at))

    def peek(self, n: int = 1) -> str:
        return self.s[self.i:self.i + n]

    def skip(self, newlines: bool) -> None:
        s = self.s
        while self.i < len(s):
            c = s[self.i]
            if c in " \t" or (newlines and c in "\r\n"):
                self.i += 1
            elif newlines and c == "#":
                end = s.find("\n", self.i)
                self.i = len(s) if end < 0 else end
            else:
                break

    def expect(self, token: str) -> None:
        if not self.s.startswith(token, self.i):
            raise _Unexpected(self.i)
        self.i += len(token)

    def string(self) -> str:
        s, quote = self.s, self.s[self.i]
        if s.startswith(quote * 3, self.i):
            end = s.find(quote * 3, self.i + 3)
            while quote == '"' and end > 0 and _escaped(s, end):
                end = s.find(quote * 3, end + 1)
            if end < 0:
                raise _Unexpected(self.i)
            while s.startswith(quote, end + 3) and end + 3 < len(s):  # up to two quotes end the content
                end += 1
            text, self.i = s[self.i + 3:end], end + 3
            return text
        if quote == "'":
            end = s.find("'", self.i + 1)
            if end < 0:
                raise _Unexpected(self.i)
            text, self.i = s[self.i + 1:end], end + 1
            return text
        out = []
        j = self.i + 1
        while j < len(s) and s[j] != '"':
            if s[j] == "\\":
                code = s[j + 1:j + 2]
                if code in ("u", "U"):
                    width = 4 if code == "u" else 8
                    out.append(chr(int(s[j + 2:j + 2 + width], 16)))
                    j += 2 + width
                    continue
                out.append(_ESCAPES.get(code, code))
                j += 2
                continue
            out.append(s[j])
            j += 1
        if j >= len(s):
            raise _Unexpected(self.i)
        self.i = j + 1
        return "".join(out)

    def key(self) -> tuple[str, ...]:
        parts = []
        while True:
            self.skip(False)
            if self.peek() in ('"', "'"):
                parts.append(self.string())
            else:
                m = _BARE.match(self.s, self.i)
                if not m:
                    raise _Unexpected(self.i)
                parts.append(m.group())
                self.i = m.end()
            self.skip(False)
            if self.peek() != ".":
                return tuple(parts)
            self.i += 1

    def value(self, path: tuple) -> None:
        c = self.peek()
        start = self.i
        if c == "{":
            self.i += 1
            self.skip(True)
            while self.peek() != "}":
                at = self.i
                key = self.key()
                self.expect("=")
                self.skip(False)
                self.record(path + key, at)
                self.value(path + key)
                self.skip(True)
                if self.peek() == ",":
                    self.i += 1
                    self.skip(True)
            self.i += 1
        elif c == "[":
            self.i += 1
            index = 0
            self.skip(True)
            while self.peek() != "]":
                self.record(path + (index,), self.i)
                self.value(path + (index,))
                index += 1
                self.skip(True)
                if self.peek() == ",":
                    self.i += 1
                    self.skip(True)
            self.i += 1
        elif c in ('"', "'"):
            self.string()
        else:
            m = _SCALAR.match(self.s, self.i)
            self.i = start + len(m.group().rstrip(" \t\r"))
        if self.i <= start:
            raise _Unexpected(start)

    def walk(self) -> None:
        table: tuple = ()
        arrays: dict[tuple, int] = {}  # array-of-tables path (indices resolved) -> tables so far

        def resolve(parts: tuple[str, ...]) -> tuple:
            path: tuple = ()
            for p in parts:
                path += (p,)
                if path in arrays:
                    path += (arrays[path] - 1,)
            return path

        while True:
            self.skip(True)
            if self.i >= len(self.s):
                return
            at = self.i
            if self.s.startswith("[[", self.i):
                self.i += 2
                parts = self.key()
                self.expect("]]")
                base = resolve(parts[:-1]) + (parts[-1],)
                arrays[base] = arrays.get(base, 0) + 1
                table = base + (arrays[base] - 1,)
                self.record(table, at)
            elif self.peek() == "[":
                self.i += 1
                table = resolve(self.key())
                self.expect("]")
                self.record(table, at)
            else:
                key = self.key()
                self.expect("=")
                self.skip(False)
                self.record(table + key, at)
                self.value(table + key)


def _escaped(s: str, i: int) -> bool:
    """Whether the character at ``i`` follows an odd number of backslashes."""
    n = 0
    while i - n - 1 >= 0 and s[i - n - 1] == "\\":
        n += 1
    return n % 2 == 1


def key_positions(text: str) -> dict[tuple, tuple[int, int]]:
    """Key path -> ``(line, column)`` of every key, table header and array element of ``text``
    (a TOML text that ``tomllib`` accepts; for any other text, the positions found up to the first
    surprise)."""
    walker = _Walker(text)
    try:
        walker.walk()
    except (_Unexpected, IndexError, ValueError, RecursionError):
        pass
    return walker.found
