"""The legacy ``.scn`` text -> :class:`Scene`, checking every rule of the scene format
(``docs/scene-format.md``, "Syntax" and "Errors").

A file is accepted as a whole or rejected with one :class:`SceneError` that lists
every problem in it, each with the file and the first line of its statement, so
that nothing invalid ever reaches Mitsuba and a user fixes a file in one go:
after a statement fails, reading goes on with the next. Reading happens in three
layers, each small:

* :func:`parse_file` turns bytes into text (missing, unreadable, binary and
  non-UTF-8 files are rejected here);
* :func:`_statements` turns text into statements: comments, blank lines, ``\\``
  continuations and ``"quoted paths"``;
* :class:`_Parser` gives each statement its meaning, defaults and constraints.

Scenes of up to millions of spheres (the sphereflake of ``make bench``) are
read on a fast path: a text without quotes, continuations or odd separators is
split line by line, and a plain ``light`` or ``sphere`` line is converted with
``float`` and accepted when every number lies clearly inside its range (a float
compared strictly with a bound decides as the exact decimal would; at a bound
the text itself is checked). Plain sphere lines are read a megabyte at a
time with numpy (:meth:`_Parser.plain_chunk`): their tokens are found in the
bytes, their four numbers converted in one pass and their attribute texts
looked up once each, and the spheres go into arrays (:class:`_SphereList`),
one object per sphere never being made; a text below :data:`ARRAYS_FROM` bytes
is read line by line in plain Python, which spares loading numpy. Every other
line, and every doubt,
goes to the careful path above, so both paths accept, reject and word their
messages alike (tests/test_parser.py checks it), and only valid input needs to
be fast.

Beyond the format's own constraints, numbers are kept where Mitsuba's 32-bit
floats stay finite and meaningful (see :data:`MAX_MAGNITUDE` and
:data:`MIN_POSITIVE`): a scene that passes here never makes the renderer
divide by zero or overflow.
"""

from __future__ import annotations

import difflib
import math
import os
import re
import stat
import struct
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

from .. import defaults
from ..defaults import MAX_DEPTH, MAX_SAMPLES, MAX_SIZE, PARALLEL_SINE
from ..errors import SceneError
from .images import image_problem
from .scene import Distinct, Light, Material, Scene, Sphere, SphereArrays, Vec3, first_use
from .vectors import cross, length, normalize

# The format's limits live in whitted.defaults (see there why each is what it is).
MAX_MAGNITUDE = Decimal(defaults.MAX_MAGNITUDE)
MIN_POSITIVE = Decimal(defaults.MIN_POSITIVE)

GLOBALS = ("size", "eye", "lookat", "up", "fov", "background", "ambient", "depth", "samples", "minweight")
STATEMENTS = GLOBALS + ("light", "sphere")
#: Sphere attribute -> names of its values (their count is the attribute's arity).
ATTRIBUTES = {
    "color": ("R", "G", "B"),
    "reflect": ("KR",),
    "refract": ("KT", "IOR"),
    "texture": ("PATH",),
    "north": ("X", "Y", "Z"),
    "equator": ("X", "Y", "Z"),
}

_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INTEGER = re.compile(r"[+-]?[0-9]+")
_NON_FINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)
_LINE_BREAK = re.compile(r"\r\n|\r|\n")
_BLANKS = " \t\f\v"

# The fast path (_Parser.parse_plain). A text holding none of these characters splits into
# the careful tokenizer's tokens with str.split(): no quotes, no continuations, no NUL, and
# none of the ASCII separators that str.split() takes for blanks but the format does not.
_NOT_PLAIN_CHARACTERS = ('"', "\\", "\x00", "\x1c", "\x1d", "\x1e", "\x1f")
_NOT_PLAIN_BYTES = tuple(c.encode() for c in _NOT_PLAIN_CHARACTERS)
#: the bytes :meth:`_Parser.plain_bytes` reads at a time (a chunk ends at a line break)
_CHUNK = 1 << 20
#: texts from this many bytes on are read with numpy into arrays (:meth:`_Parser.plain_chunk`)
ARRAYS_FROM = 1 << 20
_PLAIN_ATTRIBUTES = ("color", "reflect", "refract")
_MAX = float(defaults.MAX_MAGNITUDE)        # |x| < this: inside the magnitude limit
_MIN = float(defaults.MIN_POSITIVE)         # x > this: at least MIN_POSITIVE
_BELOW_ONE = 1.0 - 1e-12                    # reflect + refract clearly <= 1
_WHITE = (1.0, 1.0, 1.0)
_PLAIN = Material(_WHITE, 0.0, 0.0, 1.0, None)   # a sphere without attributes
_UNKNOWN = object()
_NORTH = tuple(float(c) for c in defaults.NORTH)
_EQUATOR = tuple(float(c) for c in defaults.EQUATOR)


# --------------------------------------------------------------------------- text


def parse_file(path: str | os.PathLike) -> Scene:
    """Read and parse a ``.scn`` file; errors name ``path`` as given."""
    path = Path(path)
    data = read_scene_file(path)
    if len(data) >= ARRAYS_FROM and data.isascii() and not any(c in data for c in _NOT_PLAIN_BYTES):
        # the fast path straight from the bytes: ASCII is UTF-8 without a BOM
        parser = _Parser(path)
        parser.plain_bytes(data)
        return parser.finish()
    return parse_text(decode(data, path), path)


def check_scene_file(path: str | os.PathLike) -> None:
    """Nothing, or a :class:`SceneError` naming ``path`` when it is not an existing regular
    file: the one check of a scene file, whoever reads it (the parser, the loader, and
    ``compare``'s scenes, ``.scn`` or ``.xml``). A FIFO or a device is refused before
    anything waits on reading it."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise SceneError(path, None, "no such file") from None
    except OSError as error:
        raise SceneError(path, None, f"cannot read: {error.strerror or error}") from None
    if stat.S_ISDIR(info.st_mode):
        raise SceneError(path, None, "is a folder, not a scene file")
    if not stat.S_ISREG(info.st_mode):
        raise SceneError(path, None, "is not a regular file")


def read_scene_file(path: str | os.PathLike) -> bytes:
    """The bytes of the scene file ``path`` (:func:`check_scene_file`; an unreadable one is a
    :class:`SceneError` too)."""
    check_scene_file(path)
    try:
        return Path(path).read_bytes()
    except OSError as error:
        raise SceneError(path, None, f"cannot read: {error.strerror or error}") from None


def decode(data: bytes, path: str | os.PathLike) -> str:
    """The text of a scene file's bytes: UTF-8 (a leading BOM is dropped), no NUL bytes."""
    nul = data.find(b"\0")
    if nul >= 0:
        raise SceneError(path, _line_of(data, nul), "binary file (NUL byte), not a text scene")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise SceneError(path, _line_of(data, error.start),
                         f"not UTF-8 text (byte 0x{data[error.start]:02x})") from None
    return text[1:] if text.startswith("\ufeff") else text


def _line_of(data: bytes, offset: int) -> int:
    """1-based line of byte ``offset``; the bytes before it may be any encoding."""
    head = data[:offset].decode("utf-8", errors="replace")
    return len(_LINE_BREAK.findall(head)) + 1


@dataclass(frozen=True)
class Token:
    text: str
    quoted: bool = False

    def show(self) -> str:
        """The token as written, quoted and safe for a one-line message."""
        return repr(_clip(self.text))


def _clip(text: str) -> str:
    return text if len(text) <= 40 else text[:37] + "..."


def _statements(text: str, path, errors: list) -> list[tuple[int, list[Token]]]:
    """Split ``text`` into statements: (first line number, tokens).

    ``#`` outside quotes starts a comment. A line whose text (without its
    comment and trailing blanks) ends in ``\\`` continues on the next line; the
    backslash separates tokens like a blank. A token that starts with ``"``
    runs to the next ``"`` on the same line and may hold blanks and ``#``.
    A statement that cannot be split is left out and its problem appended to
    ``errors`` as (line, message); the statements after it are still read.
    """
    statements = []
    tokens: list[Token] = []
    first = 0
    skipping = False  # the continuation lines of a statement that could not be split
    lines = _LINE_BREAK.split(text)
    if len(lines) > 1 and lines[-1] == "":
        lines.pop()  # the final line break ends the last line; no empty line follows it
    for number, line in enumerate(lines, start=1):
        if skipping:
            skipping = line.rstrip(_BLANKS).endswith("\\")
            continue
        if not tokens:
            first = number
        try:
            line_tokens, continued = _split_line(line, path, first)
        except SceneError as error:
            errors.append((error.line, error.message))
            tokens = []
            skipping = line.rstrip(_BLANKS).endswith("\\")
            continue
        tokens += line_tokens
        if continued:
            if number == len(lines):
                errors.append((first, "the last line ends with '\\' but no line follows"))
            continue
        if tokens:
            statements.append((first, tokens))
        tokens = []
    return statements


def _split_line(line: str, path, first: int) -> tuple[list[Token], bool]:
    """Tokens of one physical line, and whether it ends with a continuation ``\\``."""
    if "\0" in line:
        raise SceneError(path, first, "binary file (NUL character), not a text scene")
    tokens: list[Token] = []
    i, n = 0, len(line)
    while i < n:
        c = line[i]
        if c in _BLANKS:
            i += 1
        elif c == "#":
            break
        elif c == '"':
            end = line.find('"', i + 1)
            if end < 0:
                raise SceneError(path, first, f"unterminated quote: {line[i:][:40]!r}")
            if end + 1 < n and line[end + 1] not in _BLANKS + "#":
                raise SceneError(path, first, f"a closing quote must be followed by a blank, "
                                              f"got {line[i:end + 2][:40]!r}")
            tokens.append(Token(line[i + 1:end], quoted=True))
            i = end + 1
        else:
            j = i
            while j < n and line[j] not in _BLANKS and line[j] not in '#"':
                j += 1
            if j < n and line[j] == '"':
                raise SceneError(path, first, f"a quote may only start a value, "
                                              f"got {line[i:j + 1][:40]!r}")
            tokens.append(Token(line[i:j]))
            i = j
    continued = bool(tokens) and not tokens[-1].quoted and tokens[-1].text.endswith("\\")
    if continued:
        rest = tokens[-1].text[:-1]
        tokens[-1:] = [Token(rest)] if rest else []
    return tokens, continued


def parse_text(text: str, source: str | os.PathLike) -> Scene:
    """Parse scene text; ``source`` names the file in messages and anchors relative textures."""
    return _parse(text, source, fast=True)


def _parse(text: str, source: str | os.PathLike, *, fast: bool, arrays: bool | None = None) -> Scene:
    """:func:`parse_text`; ``fast=False`` takes the careful path for every statement, and
    ``arrays`` True or False the fast path with numpy or without, whatever the size (for tests)."""
    source = Path(source)
    if text.startswith("\ufeff"):
        text = text[1:]
    parser = _Parser(source)
    if fast and not any(c in text for c in _NOT_PLAIN_CHARACTERS):
        parser.parse_plain(text, arrays)
    else:
        parser.parse(_statements(text, source, parser.errors))
    return parser.finish()


# ---------------------------------------------------------------------- statements


def suggest(word: str, known) -> str:
    """', did you mean 'x'?' for the nearest known name, or the list of known names."""
    word = word.lower()
    ranked = sorted(known, key=lambda k: (-difflib.SequenceMatcher(None, word, k).ratio(), k))
    best = ranked[0]
    if difflib.SequenceMatcher(None, word, best).ratio() >= 0.5:
        return f"; did you mean '{best}'?"
    return "; known names: " + ", ".join(known)


class _PartsFailed(Exception):
    """A statement failed in parts whose errors :meth:`_Parser.part` has noted already."""


class _Parser:
    def __init__(self, source: Path):
        self.source = source
        self.scene = Scene(source=source)
        self.seen: dict[str, int] = {}        # global statement -> its line
        self.errors: list[tuple[int | None, str]] = []   # (line, message) of every problem
        self.failed: set[str] = set()         # the statements (names) that had a problem
        self.line = 0
        self._images: dict[Path, str | None] = {}
        self.exact: set[str] = set()                          # fast path: tokens exactly 0 or 1
        self._materials: dict[str, Material | None] = {}     # fast path: attribute text -> material
        self._tails: dict[bytes, int] = {}    # fast path: attribute bytes -> material index, or -1
        self.spheres = _SphereList()          # the spheres read so far

    def fail(self, message: str):
        raise SceneError(self.source, self.line, message)

    def part(self, check, *args):
        """``check(*args)``, one independent part of a statement (a sphere's center, its
        radius, one attribute's values): its problem is noted and None returned, so that
        the statement's other parts are still checked and one line reports every error
        (:meth:`settle` then fails the statement)."""
        try:
            return check(*args)
        except SceneError as error:
            self.errors.append((error.line, error.message))
            return None

    def settle(self, errors_before: int) -> None:
        """Fail the statement (its errors already noted) if a :meth:`part` of it failed."""
        if len(self.errors) > errors_before:
            raise _PartsFailed

    # ---- values

    def number(self, token: Token, what: str, *, integer: bool = False) -> Decimal:
        """The exact value of a number token (constraints compare what was written)."""
        text = _clip(token.text)
        if token.quoted:
            self.fail(f"{what} must be a number, got the quoted text {token.show()} "
                      f"(only texture paths are quoted)")
        if (_INTEGER if integer else _NUMBER).fullmatch(token.text):
            value = Decimal(token.text)
            if not integer and abs(value) > MAX_MAGNITUDE:  # integers have their own ranges
                self.fail(f"{what} must lie within -1e12 and 1e12, got {text}")
            return value
        if _NON_FINITE.fullmatch(token.text):
            self.fail(f"{what} must be a finite number, got {text}")
        if integer and _NUMBER.fullmatch(token.text):
            self.fail(f"{what} must be an integer, got {text}")
        kind = "an integer" if integer else "a number"
        self.fail(f"{what} must be {kind}, got {token.show()}")

    def vector(self, tokens: list[Token], what: str) -> tuple[Decimal, Decimal, Decimal]:
        return tuple(self.number(t, what) for t in tokens)

    def count(self, keyword: str, args: list[Token], names: str, *counts: int) -> None:
        if len(args) not in counts:
            wanted = " or ".join(str(c) for c in counts)
            noun = "value" if counts == (1,) else "values"
            self.fail(f"{keyword} takes {wanted} {noun} ({names}), got {len(args)}")

    def in_range(self, value: Decimal, token_text: str, what: str, low, high,
                 *, low_open: bool = False, high_open: bool = False) -> None:
        """``low <= value <= high`` (or strict where open); None means unbounded."""
        token_text = _clip(token_text)
        bad_low = low is not None and (value <= low if low_open else value < low)
        bad_high = high is not None and (value >= high if high_open else value > high)
        if not (bad_low or bad_high):
            return
        if low is not None and high is not None:
            left, right = (">" if low_open else ">="), ("<" if high_open else "<=")
            self.fail(f"{what} must be {left} {low} and {right} {high}, got {token_text}")
        if low is not None:
            self.fail(f"{what} must be {'>' if low_open else '>='} {low}, got {token_text}")
        self.fail(f"{what} must be {'<' if high_open else '<='} {high}, got {token_text}")

    def positive(self, value: Decimal, token_text: str, what: str) -> None:
        self.in_range(value, token_text, what, 0, None, low_open=True)
        if value < MIN_POSITIVE:
            self.fail(f"{what} must be at least 1e-6 (32-bit floats), got {token_text}")

    # ---- the file

    def parse(self, statements) -> None:
        """Give each statement, (first line, tokens), its meaning."""
        for line, tokens in statements:
            self.statement(line, tokens)

    def finish(self) -> Scene:
        """The scene, once every statement is read: the checks across statements, then
        every problem found, in file order, as one :class:`SceneError`."""
        if not self.failed & {"eye", "lookat", "up"}:  # else the camera is not what the file says
            try:
                self.check_camera()
            except SceneError as error:
                self.errors.append((error.line, error.message))
        if self.errors:
            self.errors.sort(key=lambda error: error[0] or 0)
            raise SceneError.collected([(self.source, line, message) for line, message in self.errors],
                                      defaults.MAX_REPORTED_ERRORS)
        self.scene.spheres = self.spheres.result()
        return self.scene

    def statement(self, line: int, tokens: list[Token]) -> None:
        """Give one statement its meaning, or note its problem and go on."""
        try:
            self._statement(line, tokens)
        except SceneError as error:
            self.errors.append((error.line, error.message))
            self.failed.add(tokens[0].text.lower())
        except _PartsFailed:   # its errors are noted already
            self.failed.add(tokens[0].text.lower())

    def _statement(self, line: int, tokens: list[Token]) -> None:
        self.line = line
        keyword, args = tokens[0], tokens[1:]
        name = keyword.text.lower()
        if keyword.quoted:
            self.fail(f"expected a statement name, got the quoted text {keyword.show()}")
        if name not in STATEMENTS:
            self.fail(f"unknown statement {keyword.show()}{suggest(keyword.text, STATEMENTS)}")
        if name in GLOBALS:
            if name in self.seen:
                self.fail(f"{name} given twice (first on line {self.seen[name]})")
            self.seen[name] = line
        getattr(self, f"statement_{name}")(args)

    # ---- the fast path: plain lights and spheres

    def parse_plain(self, text: str, arrays: bool | None = None) -> None:
        """Parse a text free of quotes, continuations and odd separators (see :data:`_NOT_PLAIN_CHARACTERS`):
        :meth:`plain_bytes` of its UTF-8 bytes when it is large (or ``arrays``), else line
        by line (:meth:`plain_line`)."""
        if arrays or arrays is None and len(text) >= ARRAYS_FROM:
            self.plain_bytes(text.encode("utf-8", "surrogatepass"))
            return
        lines = _LINE_BREAK.split(text) if "\r" in text else text.split("\n")
        if len(lines) > 1 and lines[-1] == "":
            lines.pop()  # the final line break ends the last line; no empty line follows it
        for number, line in enumerate(lines, start=1):
            self.plain_line(number, line)

    def plain_bytes(self, data: bytes) -> None:
        """Parse the UTF-8 bytes of a text free of quotes, continuations and odd separators.

        Every line is split on blanks; a plain ``light`` or ``sphere`` statement
        whose numbers all lie clearly inside their ranges is taken as it is
        (:meth:`plain_chunk`, :meth:`plain_light`, :meth:`plain_sphere`). Any other
        line, or any doubt, goes to :meth:`statement` with the careful tokenizer's
        tokens, which decides exactly as if the whole file had gone the careful way.
        """
        self.spheres.numpy = True
        ascii_ = data.isascii()
        pos, line, n = 0, 1, len(data)
        while pos < n:
            end = data.find(b"\n", pos + _CHUNK) + 1 if pos + _CHUNK < n else n
            end = end or n
            line = self.plain_chunk(data, pos, end, line, ascii_)
            pos = end

    def plain_chunk(self, data: bytes, pos: int, end: int, first: int, ascii_: bool) -> int:
        """Parse the lines of ``data[pos:end]`` (whole lines; the first is line ``first``) and
        return the number of the line after them.

        The plain sphere lines are read here, with numpy on the bytes: a line whose code
        (the text before a ``#``) holds only ASCII without ``_`` and no control character
        but the blanks splits on blanks as ``str.split`` would split it, and when its
        first token is ``sphere`` (in any case), it has at least five tokens, its four
        numbers are clearly in range and its attributes are a plain material
        (:meth:`plain_material`), it is the sphere :meth:`plain_sphere` would make of it.
        Every other line goes to :meth:`plain_line`, in file order.
        """
        import numpy as np
        b = np.frombuffer(data, np.uint8, end - pos, pos)
        m = len(b)
        ctrl = b < 32
        # line breaks: \n, \r\n or \r; line k spans starts[k]:ends[k]
        if data.find(b"\r", pos, end) < 0:
            ends = np.flatnonzero(b == 10)
            nexts = ends + 1
        else:
            cr = b == 13
            lf_alone = b == 10
            lf_alone[1:] &= ~cr[:-1]
            ends = np.flatnonzero(cr | lf_alone)
            nexts = ends + 1
            nexts[cr[ends] & (b[np.minimum(nexts, m - 1)] == 10) & (nexts < m)] += 1
        breaks = len(ends)
        starts = np.concatenate(([0], nexts))
        ends = np.concatenate((ends, [m]))
        if starts[-1] == m:       # the chunk ends with a line break: no line after it
            starts, ends = starts[:-1], ends[:-1]
        lines = len(starts)
        sep = ctrl | (b == 32)
        code_end = ends
        hashes = np.flatnonzero(b == 35) if data.find(b"#", pos, end) >= 0 else None
        if hashes is not None:    # a comment runs from a line's first '#' to its end
            holder, first_hash = np.unique(np.searchsorted(ends, hashes, "right"), return_index=True)
            code_end = ends.copy()
            code_end[holder] = hashes[first_hash]
            edges = np.zeros(m + 1, np.int8)
            edges[hashes[first_hash]] = 1
            edges[ends[holder]] -= 1
            sep |= np.cumsum(edges[:m], dtype=np.int8).view(bool)
        # lines whose code holds what str.split and float() read otherwise: non-ASCII bytes,
        # '_' or a control character that is no blank
        blank_codes = np.array(_BLANK_CODES, np.uint8)
        odd_control = np.isin(b[ctrl], blank_codes, invert=True).any()
        doubtful = np.zeros(lines, bool)
        if not ascii_ or odd_control or data.find(b"_", pos, end) >= 0:
            odd = (b == 95) | (b >= 128)
            if odd_control:
                odd |= ctrl & np.isin(b, blank_codes, invert=True)
            where = np.flatnonzero(odd)
            holder = np.searchsorted(ends, where, "right")
            doubtful[holder[where < code_end[holder]]] = True
        # tokens: token k spans token_start[k]:token_end[k]
        edges = np.diff((~sep).view(np.int8), prepend=np.int8(0), append=np.int8(0))
        token_start = np.flatnonzero(edges == 1)
        token_end = np.flatnonzero(edges == -1)
        first_token = np.searchsorted(token_start, starts)
        counts = np.diff(np.append(first_token, len(token_start)))
        # the plain sphere lines: 'sphere' and at least four more tokens
        candidates = np.flatnonzero((counts >= 5) & ~doubtful)
        keyword = first_token[candidates]
        at = token_start[keyword]
        is_sphere = token_end[keyword] - at == 6
        for k, c in enumerate(b"sphere"):
            is_sphere &= (b[np.minimum(at + k, m - 1)] | 0x20) == c
        candidates, keyword = candidates[is_sphere], keyword[is_sphere]
        accepted = np.zeros(lines, bool)
        if len(candidates):
            accepted[candidates] = self.plain_spheres(data, pos, b, candidates + first, keyword,
                                                      counts[candidates], token_start, token_end)
        rest = np.flatnonzero(((counts > 0) | doubtful) & ~accepted)
        for k, a, z in zip(rest.tolist(), starts[rest].tolist(), ends[rest].tolist()):
            self.plain_line(first + k, data[pos + a:pos + z].decode("utf-8", "surrogatepass"))
        return first + breaks

    def plain_spheres(self, data, pos, b, lines, keyword, counts, token_start, token_end) -> np.ndarray:
        """Add the spheres of the sphere lines ``lines`` (numbers) of the chunk ``b`` at ``pos``
        of ``data`` whose first tokens are ``keyword`` (indices into ``token_start`` and
        ``token_end``) and that have ``counts`` tokens; return which were taken."""
        import numpy as np
        m = len(b)
        # the four numbers of every line as one text, each line's followed by a blank
        first, fourth = token_start[keyword + 1], token_end[keyword + 4]
        last = np.minimum(fourth + 1, m)
        edges = np.zeros(m + 1, np.int8)
        edges[first] = 1
        edges[last] -= 1
        text = b[np.cumsum(edges[:m], dtype=np.int8).view(bool)]
        text[(np.cumsum(last - first) - 1)[last > fourth]] = 32   # the byte after: a blank or '#'
        tokens = text.tobytes().split()
        try:
            numbers = np.fromiter(map(float, tokens), np.float64, len(tokens))
        except ValueError:
            numbers = np.array([_float_or_nan(t) for t in tokens], np.float64)
        numbers = numbers.reshape(-1, 4)
        ok = (np.abs(numbers[:, :3]) < _MAX).all(axis=1)
        radius = numbers[:, 3]
        ok &= (radius > _MIN) & (radius < _MAX)
        # the attributes, read once per distinct text: lines whose attribute texts have the
        # same length are compared as rows of bytes
        material = np.full(len(lines), self.spheres.material(_PLAIN), np.int64)
        tails = np.flatnonzero(counts > 5)
        if len(tails):
            start = token_start[keyword[tails] + 5]
            size = token_end[keyword[tails] + counts[tails] - 1] - start
            for length in np.unique(size).tolist():
                group = tails[size == length] if len(tails) > 1 else tails
                rows = b[start[size == length][:, None] + np.arange(length)]
                if (rows == rows[0]).all():
                    material[group] = self.plain_tail(rows[0].tobytes())
                else:
                    texts, which = np.unique(rows.view(f"S{length}").ravel(), return_inverse=True)
                    material[group] = np.array([self.plain_tail(t) for t in texts.tolist()])[which]
            ok &= material >= 0
        if ok.all():
            self.spheres.add_arrays(lines, numbers[:, :3], radius, material)
        else:
            self.spheres.add_arrays(lines[ok], numbers[ok, :3], radius[ok], material[ok])
        return ok

    def plain_tail(self, text: bytes) -> int:
        """The material index of a plain sphere's attributes ``text``, or -1 when they are
        not plain (:meth:`plain_material`)."""
        index = self._tails.get(text)
        if index is None:
            found = self.plain_material(text.decode("ascii").split())
            index = self._tails[text] = -1 if found is None else self.spheres.material(found)
        return index

    def plain_line(self, number: int, line: str) -> None:
        """One line of a plain text, on the fast path if it can, else on the careful one."""
        hash_ = line.find("#")
        code = line if hash_ < 0 else line[:hash_]
        tokens = code.split(None, 5)
        if not tokens:
            if not code.isascii():  # blanks the format does not know may be tokens
                self.careful_line(number, line)
            return
        # Python's float() reads exactly the format's numbers in ASCII text without '_'
        # (and nan/inf, which fail every range check).
        if code.isascii() and "_" not in code:
            keyword = tokens[0]
            if keyword == "sphere" or keyword.lower() == "sphere":
                if self.plain_sphere(number, tokens):
                    return
            elif keyword == "light" or keyword.lower() == "light":
                if self.plain_light(number, code.split()):
                    return
        self.careful_line(number, line)

    def careful_line(self, number: int, line: str) -> None:
        tokens, _ = _split_line(line, self.source, number)
        if tokens:
            self.statement(number, tokens)

    def bound(self, token: str, value: float) -> bool:
        """Whether ``token``, which reads as the float ``value``, is exactly ``value``.

        For a float equal to a bound (0, 1): the text may lie a little beyond it
        ("1.00000000000000001"). Exact tokens are remembered in :attr:`exact`.
        """
        if Decimal(token) == Decimal(value):
            self.exact.add(token)
            return True
        return False

    def plain_light(self, line: int, tokens: list[str]) -> bool:
        """Add ``light X Y Z [R G B]`` and return True, or False to leave it to :meth:`statement`."""
        n = len(tokens)
        if n != 4 and n != 7:
            return False
        try:
            x, y, z = position = tuple(map(float, tokens[1:4]))
            r, g, b = color = _WHITE if n == 4 else tuple(map(float, tokens[4:7]))
        except ValueError:
            return False
        if not (-_MAX < x < _MAX and -_MAX < y < _MAX and -_MAX < z < _MAX):
            return False
        if not (0.0 < r < _MAX and 0.0 < g < _MAX and 0.0 < b < _MAX):
            for c, token in zip(color, tokens[4:]):
                if not (0.0 < c < _MAX or token in self.exact or c == 0.0 and self.bound(token, c)):
                    return False
        self.scene.lights.append(Light(position, color, line=line))
        return True

    def plain_sphere(self, line: int, tokens: list[str]) -> bool:
        """Add ``sphere CX CY CZ R [attributes]`` and return True, or False to leave it to
        :meth:`statement`. ``tokens`` are the line split at its first five blanks: the
        attributes come as one text, :meth:`plain_material` reads them (once per text).

        A float compared strictly with a bound decides as the exact decimal would
        (correctly rounded conversion is monotonic); a float equal to a bound is
        accepted only when its text is exactly that bound (:meth:`bound`).
        """
        if len(tokens) < 5:
            return False
        try:
            x, y, z, radius = map(float, tokens[1:5])
        except ValueError:
            return False
        if not (-_MAX < x < _MAX and -_MAX < y < _MAX and -_MAX < z < _MAX and _MIN < radius < _MAX):
            return False
        if len(tokens) == 5:
            material = _PLAIN
        else:
            material = self._materials.get(tokens[5], _UNKNOWN)
            if material is _UNKNOWN:
                material = self._materials[tokens[5]] = self.plain_material(tokens[5].split())
            if material is None:
                return False
        self.spheres.add(Sphere((x, y, z), radius, material, _NORTH, _EQUATOR, line=line))
        return True

    def plain_material(self, tokens: list[str]) -> Material | None:
        """The material of the attributes ``[color R G B] [reflect KR] [refract KT IOR]``
        in any order, or None when they are anything else or not clearly valid."""
        exact = self.exact
        color = kr = kt = None
        ior = 1.0
        i, n = 0, len(tokens)
        try:
            while i < n:
                name = tokens[i].lower()
                if name == "color" and color is None and i + 3 < n:
                    r, g, b = color = tuple(map(float, tokens[i + 1:i + 4]))
                    if not (0.0 < r < 1.0 and 0.0 < g < 1.0 and 0.0 < b < 1.0):
                        for c, token in zip(color, tokens[i + 1:i + 4]):
                            if not (0.0 < c < 1.0 or token in exact
                                    or (c == 0.0 or c == 1.0) and self.bound(token, c)):
                                return None
                    i += 4
                elif name == "reflect" and kr is None and i + 1 < n:
                    kr = float(tokens[i + 1])
                    if not (0.0 < kr < 1.0 or tokens[i + 1] in exact
                            or (kr == 0.0 or kr == 1.0) and self.bound(tokens[i + 1], kr)):
                        return None
                    i += 2
                elif name == "refract" and kt is None and i + 2 < n:
                    kt, ior = float(tokens[i + 1]), float(tokens[i + 2])
                    if not (0.0 < kt < 1.0 or tokens[i + 1] in exact
                            or (kt == 0.0 or kt == 1.0) and self.bound(tokens[i + 1], kt)):
                        return None
                    if not _MIN < ior < _MAX:
                        return None
                    i += 3
                else:
                    return None
        except ValueError:
            return None
        if kr and kt and not kr + kt <= _BELOW_ONE:  # the float sum's error is far below this margin
            return None
        return Material(_WHITE if color is None else color, 0.0 if kr is None else kr,
                        0.0 if kt is None else kt, ior, None)

    def statement_size(self, args):
        self.count("size", args, "W H", 2)
        width, height = (self.number(t, f"size {n}", integer=True) for t, n in zip(args, ("width", "height")))
        for value, token, n in ((width, args[0], "width"), (height, args[1], "height")):
            self.in_range(value, token.text, f"size {n}", 1, MAX_SIZE)
        self.scene.width, self.scene.height = int(width), int(height)

    def _point(self, name, args) -> Vec3:
        self.count(name, args, "X Y Z", 3)
        return _floats(self.vector(args, name))

    def statement_eye(self, args):
        self.scene.eye = self._point("eye", args)

    def statement_lookat(self, args):
        self.scene.lookat = self._point("lookat", args)

    def statement_up(self, args):
        self.scene.up = self._point("up", args)
        if _is_zero(self.scene.up):
            self.fail("up must not be zero")

    def statement_fov(self, args):
        self.count("fov", args, "DEG", 1)
        fov = self.number(args[0], "fov")
        self.in_range(fov, args[0].text, "fov", 0, 180, low_open=True, high_open=True)
        self.positive(fov, args[0].text, "fov")
        if _float32(float(fov)) >= 180.0:
            self.fail(f"fov must be < 180 (it rounds to 180 in 32-bit floats), got {args[0].text}")
        self.scene.fov = float(fov)

    def statement_background(self, args):
        self.count("background", args, "R G B", 3)
        color = self.vector(args, "background color")
        for value, token in zip(color, args):
            self.in_range(value, token.text, "background color", 0, None)
        self.scene.background = _floats(color)

    def _one_number(self, args, statement, placeholder, low, high, integer=False):
        """The single number of a one-number statement, checked against [low, high]."""
        self.count(statement, args, placeholder, 1)
        value = self.number(args[0], statement, integer=integer)
        self.in_range(value, args[0].text, statement, low, high)
        return int(value) if integer else float(value)

    def statement_ambient(self, args):
        self.scene.ambient = self._one_number(args, "ambient", "A", 0, 1)

    def statement_depth(self, args):
        self.scene.depth = self._one_number(args, "depth", "N", 1, MAX_DEPTH, integer=True)

    def statement_samples(self, args):
        self.scene.samples = self._one_number(args, "samples", "N", 1, MAX_SAMPLES, integer=True)

    def statement_minweight(self, args):
        self.scene.min_weight = self._one_number(args, "minweight", "W", 0, 1)

    def statement_light(self, args):
        self.count("light", args, "X Y Z [R G B]", 3, 6)
        errors = len(self.errors)
        position = self.part(self.vector, args[:3], "light position")
        color = self.part(self.light_color, args[3:]) if len(args) == 6 else (1, 1, 1)
        self.settle(errors)
        self.scene.lights.append(Light(_floats(position), _floats(color), line=self.line))

    def light_color(self, args):
        color = self.vector(args, "light color")
        for value, token in zip(color, args):
            self.in_range(value, token.text, "light color", 0, None)
        return color

    def sphere_radius(self, token):
        radius = self.number(token, "sphere radius")
        self.positive(radius, token.text, "sphere radius")
        return radius

    def statement_sphere(self, args):
        numbers = 0
        while numbers < len(args) and not args[numbers].quoted and _NUMBER.fullmatch(args[numbers].text):
            numbers += 1
        if numbers < 4:
            if numbers < len(args) and not _looks_like_name(args[numbers]):
                self.number(args[numbers], "sphere " + ("center" if numbers < 3 else "radius"))
            self.fail(f"sphere takes 4 numbers (CX CY CZ RADIUS), got {numbers}")
        if numbers > 4:
            self.fail(f"sphere takes 4 numbers (CX CY CZ RADIUS) before its attributes, got {numbers}")
        errors = len(self.errors)
        center = self.part(self.vector, args[:3], "sphere center")
        radius = self.part(self.sphere_radius, args[3])
        values = self.attributes(args[4:])
        self.settle(errors)

        kr, kt = values.get("reflect", (0,))[0], values.get("refract", (0, 1))[0]
        if kr + kt > 1:
            self.fail(f"sphere reflect + refract must be <= 1, got {kr} + {kt}")
        north = _floats(values.get("north", Sphere.north))
        equator = _floats(values.get("equator", Sphere.equator))
        if _is_zero(north):
            self.fail("sphere north must not be zero")
        if _is_zero(equator):
            self.fail("sphere equator must not be zero")
        if _sine(north, equator) < PARALLEL_SINE:
            default = "" if "equator" in values else " (the default)"
            self.fail(f"sphere equator {_show_vec(equator)}{default} must not be parallel "
                      f"to north {_show_vec(north)}")
        material = Material(
            color=_floats(values.get("color", Material.color)),
            reflect=float(kr),
            refract=float(kt),
            ior=float(values.get("refract", (0, 1))[1]),
            texture=values.get("texture"),
        )
        self.spheres.add(Sphere(_floats(center), float(radius), material, north, equator, line=self.line))

    def attributes(self, args: list[Token]) -> dict:
        """The sphere attributes after the radius, checked and converted."""
        values: dict = {}
        i = 0
        while i < len(args):
            token = args[i]
            name = token.text.lower()
            if token.quoted:
                self.fail(f"expected a sphere attribute name, got the quoted text {token.show()}")
            if name not in ATTRIBUTES:
                if _NUMBER.fullmatch(token.text):
                    self.fail(f"expected a sphere attribute name, got the number {token.text}; "
                              f"attributes are {', '.join(ATTRIBUTES)}")
                self.fail(f"unknown sphere attribute {token.show()}{suggest(token.text, ATTRIBUTES)}")
            if name in values:
                self.fail(f"sphere attribute {name} given twice")
            names = ATTRIBUTES[name]
            given = args[i + 1:i + 1 + len(names)]
            # Stop at the next attribute name so the message counts what was given.
            for k, value in enumerate(given):
                if not value.quoted and value.text.lower() in ATTRIBUTES and name != "texture":
                    given = given[:k]
                    break
            if len(given) < len(names):
                self.fail(f"sphere {name} takes {len(names)} "
                          f"{'value' if len(names) == 1 else 'values'} ({' '.join(names)}), "
                          f"got {len(given)}")
            values[name] = self.part(getattr(self, f"attribute_{name}"), given)
            i += 1 + len(names)
        return values

    def attribute_color(self, args):
        color = self.vector(args, "sphere color")
        for value, token in zip(color, args):
            self.in_range(value, token.text, "sphere color", 0, 1)
        return color

    def attribute_reflect(self, args):
        kr = self.number(args[0], "sphere reflect")
        self.in_range(kr, args[0].text, "sphere reflect", 0, 1)
        return (kr,)

    def attribute_refract(self, args):
        kt = self.number(args[0], "sphere refract KT")
        self.in_range(kt, args[0].text, "sphere refract KT", 0, 1)
        ior = self.number(args[1], "sphere refract IOR")
        self.positive(ior, args[1].text, "sphere refract IOR")
        return kt, ior

    def attribute_north(self, args):
        return self.vector(args, "sphere north")

    def attribute_equator(self, args):
        return self.vector(args, "sphere equator")

    def attribute_texture(self, args) -> Path:
        token = args[0]
        if not token.text:
            self.fail("sphere texture path is empty")
        if any(ord(c) < 32 or ord(c) == 127 for c in token.text):
            self.fail(f"sphere texture path {token.show()} holds a control character")
        path = Path(os.path.abspath(self.source.parent / token.text))
        try:
            str(path).encode("utf-8")
        except UnicodeEncodeError:
            self.fail(f"sphere texture path {path} is not valid UTF-8")
        problem = self.image_problem(path)
        if problem:
            self.fail(f"sphere texture {token.show()}: {problem}")
        return path

    def image_problem(self, path: Path) -> str | None:
        """Why Mitsuba could not use ``path`` as a texture, or None (cached per parse)."""
        if path not in self._images:
            self._images[path] = image_problem(path)
        return self._images[path]

    # ---- checks across statements

    def check_camera(self) -> None:
        scene, seen = self.scene, self.seen
        view = tuple(b - a for a, b in zip(scene.eye, scene.lookat))
        if _is_zero(view):
            self.line = max(seen.get("eye", 0), seen.get("lookat", 0))
            self.fail(f"eye and lookat must differ, both are {_show_vec(scene.eye)}")
        if sum(c * c for c in view) < 1e-300:  # Mitsuba's look_at would divide by zero
            self.line = max(seen.get("eye", 0), seen.get("lookat", 0))
            self.fail(f"eye and lookat are too close together to give a direction "
                      f"({_show_vec(scene.eye)} and {_show_vec(scene.lookat)})")
        if _sine(view, scene.up) < PARALLEL_SINE:
            self.line = seen.get("up") or max(seen.get("eye", 0), seen.get("lookat", 0))
            default = "" if "up" in seen else " (the default)"
            self.fail(f"up {_show_vec(scene.up)}{default} must not be parallel to the viewing "
                      f"direction (from eye {_show_vec(scene.eye)} to lookat {_show_vec(scene.lookat)})")


# ------------------------------------------------------------------------- helpers


#: the control characters that are blanks or line breaks (the format's and str.split's alike)
_BLANK_CODES = (9, 10, 11, 12, 13)


def _float_or_nan(token: bytes) -> float:
    try:
        return float(token)
    except ValueError:
        return math.nan


class _SphereList:
    """The spheres of a file as they are read: arrays of many (the fast path) and single
    :class:`Sphere` objects, each with its line; :meth:`arrays` puts them in file order."""

    def __init__(self):
        self.blocks: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.singles: list[Sphere] = []
        self.materials = Distinct()
        self.numpy = False    # whether numpy read spheres (else the singles are in file order)

    def material(self, material: Material) -> int:
        """The index of ``material`` (by value)."""
        return self.materials.index(material)

    def add(self, sphere: Sphere) -> None:
        self.singles.append(sphere)

    def add_arrays(self, lines, centers, radii, materials) -> None:
        """Spheres of the default orientation: their lines, centers (N×3), radii and
        material indices (:meth:`material`)."""
        if len(lines):
            self.blocks.append((lines, centers, radii, materials))

    def result(self) -> list[Sphere] | SphereArrays:
        """The spheres in file order: as :meth:`arrays` when numpy read some, else as a list."""
        return self.arrays() if self.numpy else self.singles

    def arrays(self) -> SphereArrays:
        import numpy as np
        blocks = list(self.blocks)
        orientations = Distinct()
        orientations.index((_NORTH, _EQUATOR))
        if self.singles:
            singles = self.singles
            n = len(singles)
            blocks.append((
                np.fromiter((s.line for s in singles), np.int64, n),
                np.array([s.center for s in singles], np.float64).reshape(n, 3),
                np.fromiter((s.radius for s in singles), np.float64, n),
                np.fromiter((self.material(s.material) for s in singles), np.int64, n)))
            single_orientation = np.fromiter(
                (orientations.index((s.north, s.equator)) for s in singles), np.int64, n)
        if not blocks:
            return SphereArrays(np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64), (),
                                np.zeros(0, np.int64), np.zeros(0, np.int64), ())
        line, center, radius, material = (np.concatenate(parts) for parts in zip(*blocks))
        orientation = np.zeros(len(line), np.int64)
        if self.singles:
            orientation[len(line) - len(self.singles):] = single_orientation
        if len(line) > 1 and (np.diff(line) < 0).any():
            order = np.argsort(line, kind="stable")
            line, center, radius, material, orientation = (
                a[order] for a in (line, center, radius, material, orientation))
        material, materials = _by_first_use(material, self.materials.values)
        orientation, orientations = _by_first_use(orientation, orientations.values)
        return SphereArrays(center, radius, material, materials, line, orientation, orientations)


def _by_first_use(index: np.ndarray, values: list) -> tuple[np.ndarray, tuple]:
    """``index`` renumbered so that the values it refers to come in order of first use,
    and those values."""
    import numpy as np
    order = first_use(index)
    if len(order) == len(values) and (order == np.arange(len(values))).all():
        return index, tuple(values)
    remap = np.zeros(len(values), np.int64)
    remap[order] = np.arange(len(order))
    return remap[index], tuple(values[k] for k in order.tolist())


def _looks_like_name(token: Token) -> bool:
    return not token.quoted and token.text.lower() in ATTRIBUTES


def _floats(values) -> Vec3:
    return tuple(float(v) for v in values)


def _float32(x: float) -> float:
    return struct.unpack("f", struct.pack("f", x))[0]


def _is_zero(v) -> bool:
    return all(c == 0 for c in v)


def _sine(a, b) -> float:
    """Sine of the angle between two directions (0 when either is zero)."""
    if _is_zero(a) or _is_zero(b):
        return 0.0
    return length(cross(normalize(a), normalize(b)))


def _show_vec(v) -> str:
    return " ".join(f"{c:g}" for c in v)
