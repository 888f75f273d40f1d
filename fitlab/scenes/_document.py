r"""Reading a scene file (TOML or JSON) into a document: the parsed data and, when a message needs one,
the line that sets a key path.

Positions come from the parsers themselves, never from a scanner of our own:

* syntax errors: the line tomllib's :class:`tomllib.TOMLDecodeError` and json's
  :class:`json.JSONDecodeError` report;
* a key path of a valid TOML document (``material[1].c``): the first line at which the document read up to
  that line holds the path (a prefix of valid TOML is valid TOML but where a value spans lines; such a
  prefix is read on to the line that closes the value), found by bisection;
* a key path of a valid JSON document: the start of its value, as json's own pure-Python scanner
  (``json.scanner.py_make_scanner``) reports it to the hooks it calls for every value.

Positions are computed only when a message needs them: a valid scene is parsed once, by the C parsers.
"""

from __future__ import annotations

import bisect
import json
import re
import tomllib
from json.decoder import JSONArray, JSONObject
from json.scanner import py_make_scanner
from pathlib import Path

from fitlab._io import InputFileError, read_regular_file

__all__ = ["MAX_SCENE_BYTES", "SceneError", "Document", "read_scene_text", "parse_document", "peek"]

#: the largest scene file read, in bytes
MAX_SCENE_BYTES = 1_000_000
#: the most TOML prefixes parsed to place one key path (positions are a courtesy: past it, the nearest
#: enclosing table that was placed, or line 1)
_MAX_PREFIX_PARSES = 200


class SceneError(ValueError):
    """A malformed scene (or override, or output folder); the message lists every problem, one a line, as
    ``file:line: field: what``."""


def read_scene_text(path, suffixes=(".toml", ".json"), noun: str = "scene") -> str:
    """The text of scene file ``path``: a regular file (a FIFO never blocks) of at most
    :data:`MAX_SCENE_BYTES`, UTF-8, named with one of ``suffixes``; else a one-line :class:`SceneError`
    ``PATH:1: (file): ...``."""
    p = Path(path)
    if p.suffix not in suffixes:
        raise SceneError(f"{p}:1: (file): a {noun} is a {' or '.join(suffixes)} file")
    try:  # a regular file of at most MAX_SCENE_BYTES, checked before it is opened
        return read_regular_file(p, MAX_SCENE_BYTES).decode("utf-8")
    except InputFileError as exc:
        raise SceneError(f"{p}:1: (file): {exc.refusal('scene')}") from None
    except OSError as exc:
        raise SceneError(f"{p}:1: (file): cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:  # binary garbage: TOML and JSON are UTF-8 text
        raise SceneError(
            f"{p}:1: (file): not a UTF-8 text file (byte {exc.object[exc.start]:#04x} at offset {exc.start})"
        ) from None


def _format(path, fmt: str | None) -> str:
    return fmt or ("json" if str(path).endswith(".json") else "toml")


def _syntax_line(exc: tomllib.TOMLDecodeError) -> int:
    """The line of a TOML syntax error: the exception's own (Python 3.14), else the one its message
    states (tomllib writes "(at line N, column M)"), else 1."""
    line = getattr(exc, "lineno", None)
    if isinstance(line, int):
        return line
    m = re.search(r"at line (\d+)", str(exc))
    return int(m.group(1)) if m else 1


def _holds(data, keypath) -> bool:
    for part in keypath:
        if isinstance(part, int):
            if not isinstance(data, list) or part >= len(data):
                return False
        elif not isinstance(data, dict) or part not in data:
            return False
        data = data[part]
    return True


class _TomlPositions:
    """Lines of key paths in valid TOML text, from tomllib's reading of its prefixes."""

    def __init__(self, text: str):
        self.lines = text.splitlines()
        self.prefix: dict[int, dict | None] = {}  # n lines -> parsed, or None when the prefix is no TOML
        self.budget = _MAX_PREFIX_PARSES

    def _parsed(self, n: int):
        """(m, data): the first prefix of m >= n lines that parses; None when out of budget."""
        for m in range(n, len(self.lines) + 1):
            if m not in self.prefix:
                if self.budget <= 0:
                    return None
                self.budget -= 1
                try:
                    self.prefix[m] = tomllib.loads("\n".join(self.lines[:m]))
                except tomllib.TOMLDecodeError:
                    self.prefix[m] = None
            if self.prefix[m] is not None:
                return m, self.prefix[m]
        return None

    def line(self, keypath) -> int | None:
        lo, hi, found = 1, len(self.lines), None
        while lo <= hi:  # "the prefix read on to a value's end holds the path" grows with the prefix
            mid = (lo + hi) // 2
            got = self._parsed(mid)
            if got is None:
                return found
            m, data = got
            if _holds(data, keypath):
                found, hi = m, mid - 1
            else:
                lo = m + 1
        return found


class _Positioned:
    __slots__ = ("value", "index")

    def __init__(self, value, index):
        self.value, self.index = value, index


class _PositionDecoder(json.JSONDecoder):
    """json's own pure-Python scanner, every value wrapped with the index where it starts."""

    def __init__(self):
        super().__init__()

        def positioned(string, idx):
            value, end = inner(string, idx)
            return _Positioned(value, idx), end

        # the scanner reads its hooks when it is made: set them first
        self.parse_object = lambda s_end, strict, _scan, *rest: JSONObject(s_end, strict, positioned, *rest)
        self.parse_array = lambda s_end, _scan: JSONArray(s_end, positioned)
        inner = py_make_scanner(self)
        self.scan_once = positioned


def _json_positions(text: str) -> dict:
    """key path -> index of its value's first character, for valid JSON text."""
    out = {}

    def walk(node, keypath):
        out[keypath] = node.index
        value = node.value
        if isinstance(value, dict):
            for k, v in value.items():
                walk(v, keypath + (k,))
        elif isinstance(value, list):
            for k, v in enumerate(value):
                walk(v, keypath + (k,))

    walk(_PositionDecoder().decode(text), ())
    return out


class Document:
    """A parsed scene file: ``data`` (a dict), its ``path`` and format, and :meth:`line` of a key path."""

    def __init__(self, text: str, path: str, fmt: str, data: dict):
        self.text, self.path, self.fmt, self.data = text, path, fmt, data
        self._lines: dict = {}  # key path -> line, or None where the parser places it nowhere
        self._toml: _TomlPositions | None = None
        self._json: dict | None = None
        self._newlines: list | None = None

    def _line_of(self, keypath: tuple) -> int | None:
        if self.fmt == "json":
            if self._json is None:
                try:
                    self._json = _json_positions(self.text)
                except (ValueError, RecursionError):  # positions are a courtesy: never fail on them
                    self._json = {}
            index = self._json.get(keypath)
            if index is None:
                return None
            if self._newlines is None:
                self._newlines = [i for i, ch in enumerate(self.text) if ch == "\n"]
            return bisect.bisect_left(self._newlines, index) + 1
        if self._toml is None:
            self._toml = _TomlPositions(self.text)
        return self._toml.line(keypath)

    def line(self, keypath) -> int:
        """The line that sets ``keypath`` (a tuple of keys and array indices), else the nearest enclosing
        path's, else 1."""
        p = tuple(keypath)
        while p:
            if p not in self._lines:
                self._lines[p] = self._line_of(p)
            if self._lines[p] is not None:
                return self._lines[p]
            p = p[:-1]
        return 1


def parse_document(text: str, path: str = "<scene>", fmt: str | None = None) -> Document:
    """Parse scene text (format ``fmt``, else from the suffix of ``path``: ``.json`` JSON, else TOML);
    a syntax error or a top level that is no table is a one-line :class:`SceneError`."""
    fmt = _format(path, fmt)
    try:
        data = json.loads(text) if fmt == "json" else tomllib.loads(text)
    except json.JSONDecodeError as exc:
        raise SceneError(f"{path}:{exc.lineno}: not valid JSON: {exc.msg} (column {exc.colno})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}:{_syntax_line(exc)}: not valid TOML: {exc}") from None
    if not isinstance(data, dict):
        raise SceneError(f"{path}:1: (top level): expected a table/object")
    return Document(text, str(path), fmt, data)


def peek(path) -> dict:
    """The data of scene file ``path`` as read (no check), or {} when it cannot be read or parsed."""
    try:
        return parse_document(read_scene_text(path, (Path(path).suffix,)), str(path)).data
    except SceneError:
        return {}
