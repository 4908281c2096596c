"""The legacy ``.scn`` text -> :class:`Scene`, checking every rule of the scene format
(``docs/scene-format.md``, "Syntax" and "Errors").

A file is accepted as a whole or rejected with one :class:`SceneError` that lists every
problem in it, so that nothing invalid reaches Mitsuba and a user fixes a file in one go.
Scenes of millions of spheres must read fast: sphere statements of plain lines are read a
batch at a time, their numbers with ``float`` and numpy and each distinct attribute list once;
a sphere in doubt is read again on its own by the statement reader, which alone words messages.
"""

from __future__ import annotations

import difflib
import gc
import math
import os
import re
import stat
import struct
from decimal import Decimal
from itertools import chain, compress, repeat
from operator import contains, itemgetter
from pathlib import Path

from .. import defaults
from ..defaults import MAX_DEPTH, MAX_SAMPLES, MAX_SIZE, PARALLEL_SINE
from ..errors import SceneError
from .textures import image_problem
from .scene import Distinct, Light, Material, Scene, Sphere, SphereArrays, Vec3
from .scene import cross, length, normalize

# The format's limits live in whitted.defaults (see there why each is what it is).
MAX_MAGNITUDE = Decimal(defaults.MAX_MAGNITUDE)
MIN_POSITIVE = Decimal(defaults.MIN_POSITIVE)

GLOBALS = ("size", "eye", "lookat", "up", "fov", "background", "ambient", "depth", "samples", "minweight")
STATEMENTS = GLOBALS + ("light", "sphere")
#: statement of one number -> the scene's field, its placeholder (N: an integer), its range
NUMBERS = {"ambient": ("ambient", "A", 0, 1), "depth": ("depth", "N", 1, MAX_DEPTH),
           "samples": ("samples", "N", 1, MAX_SAMPLES), "minweight": ("min_weight", "W", 0, 1)}
#: Sphere attribute -> names of its values (their count is the attribute's arity).
ATTRIBUTES = {"color": ("R", "G", "B"), "reflect": ("KR",), "refract": ("KT", "IOR"),
              "texture": ("PATH",), "north": ("X", "Y", "Z"), "equator": ("X", "Y", "Z")}

_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INTEGER = re.compile(r"[+-]?[0-9]+")
_NON_FINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)
_BLANKS = " \t\f\v"
LINE_BREAK = re.compile(r"\r\n|\r|\n")
#: what starts an XML file (no statement of the format starts with "<")
_XML_START = re.compile(r"\s*<")
#: what makes a line not plain: a plain line splits into the tokenizer's tokens with
#: str.split(), and float() reads its numbers as the format does (no quote, continuation, NUL,
#: '_', non-ASCII character or separator the format does not know)
_ODD = '"\\\x00\x1c\x1d\x1e\x1f_'
_NOT_PLAIN = re.compile(f"[{re.escape(_ODD)}]|[^\\x00-\\x7f]")
#: the sphere statements read at a time (:meth:`_Parser.read_spheres`)
_BATCH = 1 << 16
_MAX = float(defaults.MAX_MAGNITUDE)        # |x| < this: inside the magnitude limit
_MIN = float(defaults.MIN_POSITIVE)         # x > this: at least MIN_POSITIVE
#: a sphere's (north, equator) when its statement gives neither
_DEFAULT_ORIENTATION = (tuple(map(float, defaults.NORTH)), tuple(map(float, defaults.EQUATOR)))


def parse_file(path: str | os.PathLike) -> Scene:
    """Read and parse a ``.scn`` file; errors name ``path`` as given."""
    return parse_text(decode(read_scene_file(path), path), path)


def check_scene_file(path: str | os.PathLike) -> None:
    """A :class:`SceneError` naming ``path`` unless it is an existing regular file (a FIFO
    is refused before anything waits on it): the one check, whoever reads a scene file."""
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
    """The bytes of the scene file ``path``, or a :class:`SceneError`."""
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
    return text.removeprefix("\ufeff")


def _line_of(data: bytes, offset: int) -> int:
    """1-based line of byte ``offset``; the bytes before it may be any encoding."""
    head = data[:offset].decode("utf-8", errors="replace")
    return len(LINE_BREAK.findall(head)) + 1


class Quoted(str):
    """A token written in quotes (only texture paths are)."""


def _show(token: str) -> str:
    """The token as written, quoted and safe for a one-line message."""
    return repr(_clip(token))


def _clip(text: str) -> str:
    return text if len(text) <= 40 else text[:37] + "..."


def _statements(lines: list[str], path, errors: list, comments: dict):
    """The statements of ``lines``: (first line number, tokens, plain); a statement's comment
    goes into ``comments`` by that line, the problem of one that cannot be split into
    ``errors`` as (line, message). The syntax: docs/scene-format.md, "Syntax". A plain
    statement is one plain line, its tokens from :func:`_plain_words`."""
    tokens: list[str] = []
    first = 0
    remark = None   # the statement's comment
    skipping = False  # the continuation lines of a statement that could not be split
    for number, line in enumerate(lines, start=1):
        if skipping:
            skipping = line.rstrip(_BLANKS).endswith("\\")
            continue
        if not tokens and not _NOT_PLAIN.search(line):
            words = _plain_words([line], number, comments)[0]
            if words:
                yield number, words, True
            continue
        if not tokens:
            first, remark = number, None
        try:
            line_tokens, continued, line_remark = _split_line(line, path, first)
        except SceneError as error:
            errors.append((error.line, error.message))
            tokens = []
            skipping = line.rstrip(_BLANKS).endswith("\\")
            continue
        tokens += line_tokens
        remark = remark or line_remark
        if continued:
            if number == len(lines):
                errors.append((first, "the last line ends with '\\' but no line follows"))
            continue
        if tokens:
            if remark:
                comments[first] = remark
            yield first, tokens, False
        tokens = []


def _plain_words(lines: list[str], first: int, comments: dict) -> list[list[str]]:
    """The words of plain lines, the first numbered ``first``: a line's first five tokens and
    the text of the rest (:func:`_tokens`); their comments go into ``comments`` by line."""
    words = [line.split(None, 5) for line in lines]
    for k in compress(range(len(lines)), map(contains, lines, repeat("#"))):
        code, _, remark = lines[k].partition("#")
        words[k] = code.split(None, 5)
        if words[k] and remark.strip():
            comments[first + k] = remark.strip()
    return words


def _tokens(words: list[str]) -> list[str]:
    """The tokens of a plain statement, from its first five and the text of the rest."""
    return words[:5] + words[5].split() if len(words) == 6 else words


#: a token of a line (a quoted one with its quotes, perhaps unclosed), or the ``#`` of its comment
_TOKEN = re.compile(r'"[^"]*"?|#|[^ \t\f\v#"]+')


def token_spans(line: str) -> tuple[list[list[int]], bool, int]:
    """The spans ``[start, end]`` of the tokens of a line (a quoted one with its quotes),
    whether it continues on the next (a trailing ``\\``, left out of the spans), and where
    the ``#`` of its comment is (-1: nowhere)."""
    spans, comment = [], -1
    for match in _TOKEN.finditer(line):
        if match.group() == "#":
            comment = match.start()
            break
        spans.append([match.start(), match.end()])
    continued = bool(spans) and line[spans[-1][0]] != '"' and line[spans[-1][1] - 1] == "\\"
    if continued:
        spans[-1][1] -= 1
        if spans[-1][0] == spans[-1][1]:
            spans.pop()
    return spans, continued, comment


def _split_line(line: str, path, first: int) -> tuple[list[str], bool, str | None]:
    """Tokens of one physical line, whether it ends with a continuation ``\\``, its comment."""
    if "\0" in line:
        raise SceneError(path, first, "binary file (NUL character), not a text scene")
    spans, continued, comment = token_spans(line)
    tokens: list[str] = []
    for a, z in spans:
        if line[a] == '"':
            if z - a < 2 or line[z - 1] != '"':
                raise SceneError(path, first, f"unterminated quote: {line[a:][:40]!r}")
            if z < len(line) and line[z] not in _BLANKS + "#":
                raise SceneError(path, first, f"a closing quote must be followed by a blank, "
                                              f"got {line[a:z + 1][:40]!r}")
            tokens.append(Quoted(line[a + 1:z - 1]))
        elif z < len(line) and line[z] == '"':
            raise SceneError(path, first, f"a quote may only start a value, got {line[a:z + 1][:40]!r}")
        else:
            tokens.append(line[a:z])
    remark = line[comment + 1:].strip() if comment >= 0 else ""
    return tokens, continued, remark or None


def parse_text(text: str, source: str | os.PathLike, *, careful: bool = False) -> Scene:
    """Parse scene text; ``source`` names the file in messages and anchors relative textures.
    ``careful=True``: every statement read on its own, none in a batch (the parser's tests and
    benchmark compare both)."""
    parser = _Parser(Path(source))
    text = text.removeprefix("\ufeff")
    xml = _XML_START.match(text)
    if xml:
        raise SceneError(source, len(LINE_BREAK.findall(xml[0])) + 1, "XML, not a legacy scene (a Mitsuba "
                         "scene is read from a .xml file, by whitted render or mi.load_file)")
    enabled = gc.isenabled()
    gc.disable()   # a large scene makes millions of short-lived lists, none in a cycle
    try:
        _read(parser, text, careful)
        return parser.finish()
    finally:
        if enabled:
            gc.enable()


def _read(parser: _Parser, text: str, careful: bool) -> None:
    """Give every statement of ``text`` to ``parser``: the lines of a plain text a batch at a
    time, every other text's statement by statement (:func:`_statements`)."""
    lines = LINE_BREAK.split(text) if "\r" in text else text.split("\n")
    if len(lines) > 1 and lines[-1] == "":
        lines.pop()  # the final line break ends the last line; no empty line follows it
    if text.isascii() and not any(c in text for c in _ODD):    # every line plain
        for start in range(0, len(lines), _BATCH):
            chunk = lines[start:start + _BATCH]
            parser.plain(start + 1, _plain_words(chunk, start + 1, parser.scene.comments), careful)
    else:
        statements = _statements(lines, parser.source, parser.errors, parser.scene.comments)
        for line, tokens, plain in statements:
            if plain:
                parser.plain(line, [tokens], careful)
            else:
                parser.statement(line, tokens)


def suggest(word: str, known) -> str:
    """', did you mean 'x'?' for the nearest known name, or the list of known names."""
    word = word.lower()
    best = min(known, key=lambda k: (-difflib.SequenceMatcher(None, word, k).ratio(), k))
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
        self.pending_lines: list[int] = []    # plain sphere statements to read in a batch:
        self.pending: list[list[str]] = []    # their lines and words
        self.blocks: list[tuple] = []         # the spheres read: arrays of line, numbers, look
        self.rows: list[tuple] = []           # spheres read one at a time, for the next block
        self.materials, self.orientations = Distinct(), Distinct()   # (north, equator) pairs
        self.looks: dict[tuple[int, int], int] = {}   # (material, orientation) -> look
        self._tails: dict[str, int] = {}      # plain attributes' text -> look, or -1

    def fail(self, message: str):
        raise SceneError(self.source, self.line, message)

    def part(self, check, *args):
        """``check(*args)``, one independent part of a statement: its problem is noted and None
        returned, so that the other parts are still checked (:meth:`settle` fails it)."""
        try:
            return check(*args)
        except SceneError as error:
            self.errors.append((error.line, error.message))
            return None

    def settle(self, errors_before: int) -> None:
        """Fail the statement if a :meth:`part` of it failed."""
        if len(self.errors) > errors_before:
            raise _PartsFailed

    def number(self, token: str, what: str, *, integer: bool = False) -> Decimal:
        """The exact value of a number token (constraints compare what was written)."""
        if isinstance(token, Quoted):
            self.fail(f"{what} must be a number, got the quoted text {_show(token)} "
                      f"(only texture paths are quoted)")
        if (_INTEGER if integer else _NUMBER).fullmatch(token):
            value = Decimal(token)
            if not integer and abs(value) > MAX_MAGNITUDE:  # integers have their own ranges
                self.fail(f"{what} must lie within -1e12 and 1e12, got {_clip(token)}")
            return value
        if _NON_FINITE.fullmatch(token):
            self.fail(f"{what} must be a finite number, got {_clip(token)}")
        if integer and _NUMBER.fullmatch(token):
            self.fail(f"{what} must be an integer, got {_clip(token)}")
        kind = "an integer" if integer else "a number"
        self.fail(f"{what} must be {kind}, got {_show(token)}")

    def vector(self, tokens: list[str], what: str) -> tuple[Decimal, Decimal, Decimal]:
        return tuple(self.number(t, what) for t in tokens)

    def color(self, args: list[str], what: str, high=None):
        color = self.vector(args, what)
        for value, token in zip(color, args):
            self.in_range(value, token, what, 0, high)
        return color

    def bounded(self, token: str, what: str, low, high, integer: bool = False) -> Decimal:
        value = self.number(token, what, integer=integer)
        self.in_range(value, token, what, low, high)
        return value

    def count(self, keyword: str, args: list[str], names: str, *counts: int) -> None:
        if len(args) not in counts:
            wanted = " or ".join(str(c) for c in counts)
            noun = "value" if counts == (1,) else "values"
            self.fail(f"{keyword} takes {wanted} {noun} ({names}), got {len(args)}")

    def in_range(self, value: Decimal, token_text: str, what: str, low, high,
                 *, low_open: bool = False, high_open: bool = False) -> None:
        """``low <= value <= high`` (or strict where open); a ``high`` of None: unbounded."""
        bad_high = high is not None and (value >= high if high_open else value > high)
        if bad_high or (value <= low if low_open else value < low):
            bounds = f"{'>' if low_open else '>='} {low}"
            if high is not None:
                bounds += f" and {'<' if high_open else '<='} {high}"
            self.fail(f"{what} must be {bounds}, got {_clip(token_text)}")

    def positive(self, value: Decimal, token_text: str, what: str) -> None:
        self.in_range(value, token_text, what, 0, None, low_open=True)
        if value < MIN_POSITIVE:
            self.fail(f"{what} must be at least 1e-6 (32-bit floats), got {token_text}")

    def finish(self) -> Scene:
        """The scene once every statement is read, or every problem, in file order, as one
        :class:`SceneError`."""
        if not self.failed & {"eye", "lookat", "up"}:  # else the camera is not what the file says
            self.part(self.check_camera)
        self.read_spheres()
        if self.errors:
            self.errors.sort(key=lambda error: error[0] or 0)
            raise SceneError.collected([(self.source, line, message) for line, message in self.errors],
                                      defaults.MAX_REPORTED_ERRORS)
        self.scene.spheres = self.sphere_arrays()
        self.scene.comments = dict(sorted(self.scene.comments.items()))   # by line, on every path
        return self.scene

    def statement(self, line: int, tokens: list[str]) -> None:
        """Give one statement its meaning, or note its problem and go on."""
        self.line = line
        keyword, args = tokens[0], tokens[1:]
        name = keyword.lower()
        try:
            if isinstance(keyword, Quoted):
                self.fail(f"expected a statement name, got the quoted text {_show(keyword)}")
            if name not in STATEMENTS:
                self.fail(f"unknown statement {_show(keyword)}{suggest(keyword, STATEMENTS)}")
            if name in GLOBALS:
                if name in self.seen:
                    self.fail(f"{name} given twice (first on line {self.seen[name]})")
                self.seen[name] = line
            if name in ("eye", "lookat", "up"):
                self.count(name, args, "X Y Z", 3)
                setattr(self.scene, name, _floats(self.vector(args, name)))
                if name == "up" and _is_zero(self.scene.up):
                    self.fail("up must not be zero")
            elif name in NUMBERS:   # N: an integer
                field, placeholder, low, high = NUMBERS[name]
                self.count(name, args, placeholder, 1)
                value = self.bounded(args[0], name, low, high, integer=placeholder == "N")
                setattr(self.scene, field, int(value) if placeholder == "N" else float(value))
            else:
                getattr(self, f"statement_{name}")(args)
        except SceneError as error:
            self.errors.append((error.line, error.message))
            self.failed.add(name)
        except _PartsFailed:   # its errors are noted already
            self.failed.add(name)

    def statement_size(self, args):
        self.count("size", args, "W H", 2)
        width, height = (self.number(t, f"size {n}", integer=True) for t, n in zip(args, ("width", "height")))
        for value, token, n in ((width, args[0], "width"), (height, args[1], "height")):
            self.in_range(value, token, f"size {n}", 1, MAX_SIZE)
        self.scene.width, self.scene.height = int(width), int(height)

    def statement_fov(self, args):
        self.count("fov", args, "DEG", 1)
        fov = self.number(args[0], "fov")
        self.in_range(fov, args[0], "fov", 0, 180, low_open=True, high_open=True)
        self.positive(fov, args[0], "fov")
        if struct.unpack("f", struct.pack("f", float(fov)))[0] >= 180.0:
            self.fail(f"fov must be < 180 (it rounds to 180 in 32-bit floats), got {args[0]}")
        self.scene.fov = float(fov)

    def statement_background(self, args):
        self.count("background", args, "R G B", 3)
        self.scene.background = _floats(self.color(args, "background color"))

    def statement_light(self, args):
        self.count("light", args, "X Y Z [R G B]", 3, 6)
        errors = len(self.errors)
        position = self.part(self.vector, args[:3], "light position")
        color = self.part(self.color, args[3:], "light color") if len(args) == 6 else (1, 1, 1)
        self.settle(errors)
        self.scene.lights.append(Light(_floats(position), _floats(color), line=self.line))

    def sphere_radius(self, token):
        radius = self.number(token, "sphere radius")
        self.positive(radius, token, "sphere radius")
        return radius

    def statement_sphere(self, args):
        numbers = 0
        while numbers < len(args) and not isinstance(args[numbers], Quoted) and _NUMBER.fullmatch(args[numbers]):
            numbers += 1
        if numbers < 4:
            if numbers < len(args) and (isinstance(args[numbers], Quoted)
                                        or args[numbers].lower() not in ATTRIBUTES):
                self.number(args[numbers], "sphere " + ("center" if numbers < 3 else "radius"))
            self.fail(f"sphere takes 4 numbers (CX CY CZ RADIUS), got {numbers}")
        if numbers > 4:
            self.fail(f"sphere takes 4 numbers (CX CY CZ RADIUS) before its attributes, got {numbers}")
        errors = len(self.errors)
        center = self.part(self.vector, args[:3], "sphere center")
        radius = self.part(self.sphere_radius, args[3])
        look = self.look(args[4:], errors)
        self.rows.append((self.line, *_floats(center), float(radius), look))

    def look(self, args: list[str], errors: int) -> int:
        """The number of the material and orientation (:attr:`looks`) the sphere attributes
        ``args`` give; ``errors``: the count before the statement (any more: it fails)."""
        values = self.attributes(args)
        self.settle(errors)
        kr, kt = values.get("reflect", (0,))[0], values.get("refract", (0, 1))[0]
        if kr + kt > 1:
            self.fail(f"sphere reflect + refract must be <= 1, got {kr} + {kt}")
        orientation = _DEFAULT_ORIENTATION
        if "north" in values or "equator" in values:
            orientation = north, equator = (_floats(values.get("north", Sphere.north)),
                                            _floats(values.get("equator", Sphere.equator)))
            for name, direction in (("north", north), ("equator", equator)):
                if _is_zero(direction):
                    self.fail(f"sphere {name} must not be zero")
            if _sine(north, equator) < PARALLEL_SINE:
                default = "" if "equator" in values else " (the default)"
                self.fail(f"sphere equator {_show_vec(equator)}{default} must not be parallel "
                          f"to north {_show_vec(north)}")
        material = Material(_floats(values.get("color", Material.color)), float(kr), float(kt),
                            float(values.get("refract", (0, 1))[1]), values.get("texture"))
        key = self.materials.index(material), self.orientations.index(orientation)
        return self.looks.setdefault(key, len(self.looks))

    def tail_look(self, tail: str) -> int:
        """:meth:`look` of a plain sphere statement's attributes, the text ``tail``, read once
        per distinct text, or -1 when they have a problem (:meth:`statement` then words it)."""
        found = self._tails.get(tail)
        if found is None:
            errors = len(self.errors)
            try:
                found = self.look(tail.split(), errors)
            except (SceneError, _PartsFailed):
                found = -1
            del self.errors[errors:]
            self._tails[tail] = found
        return found

    def plain(self, first: int, words: list[list[str]], careful: bool) -> None:
        """The statements of plain lines, the first numbered ``first``, their words from
        :func:`_plain_words`: the spheres go to a batch (:meth:`read_spheres`) unless ``careful``."""
        spheres = [not careful and len(w) >= 5 and (w[0] == "sphere" or w[0].lower() == "sphere")
                   for w in words]
        if words.count([]) + sum(spheres) < len(words):
            for k in compress(range(len(words)), words):
                if not spheres[k]:
                    self.statement(first + k, _tokens(words[k]))
        self.pending_lines += compress(range(first, first + len(words)), spheres)
        self.pending += compress(words, spheres)
        if len(self.pending) >= _BATCH:
            self.read_spheres()

    def read_spheres(self) -> None:
        """Read the pending sphere statements: at once those whose numbers lie clearly inside
        their ranges and whose attributes are valid, every other one by :meth:`statement`."""
        import numpy as np
        statements, lines = self.pending, self.pending_lines
        self.pending, self.pending_lines = [], []
        n = len(statements)
        texts = chain.from_iterable(map(itemgetter(slice(1, 5)), statements))
        try:
            numbers = np.fromiter(map(float, texts), np.float64, 4 * n).reshape(n, 4)
        except ValueError:   # nan fails every range below
            texts = chain.from_iterable(map(itemgetter(slice(1, 5)), statements))
            numbers = np.fromiter(map(_float_or_nan, texts), np.float64, 4 * n).reshape(n, 4)
        radius = numbers[:, 3]
        ok = (np.abs(numbers[:, :3]) < _MAX).all(axis=1) & (radius > _MIN) & (radius < _MAX)
        tails = [words[5] if len(words) == 6 else "" for words in statements]
        look = np.fromiter(map(self._tails.get, tails, repeat(-2)), np.int64, n)   # -2: not yet read
        for k in np.flatnonzero(look == -2).tolist():
            look[k] = self.tail_look(tails[k])
        ok &= look >= 0
        for k in np.flatnonzero(~ok).tolist():
            self.statement(lines[k], _tokens(statements[k]))
        self.blocks.append((np.array(lines, np.int64)[ok], numbers[ok], look[ok]))
        if self.rows:
            rows = np.array(self.rows, np.float64).reshape(-1, 6)
            self.rows = []
            self.blocks.append((rows[:, 0].astype(np.int64), rows[:, 1:5], rows[:, 5].astype(np.int64)))

    def sphere_arrays(self) -> SphereArrays:
        """The spheres read, in file order, their materials and orientations by first use."""
        import numpy as np
        line, numbers, look = (np.concatenate(parts) for parts in zip(*self.blocks))
        if len(line) > 1 and (np.diff(line) < 0).any():
            order = np.argsort(line, kind="stable")
            line, numbers, look = line[order], numbers[order], look[order]
        pairs = np.array(list(self.looks), np.int64).reshape(-1, 2)
        material, orientation = pairs[look, 0], pairs[look, 1]
        material, materials = _by_first_use(material, self.materials.values)
        orientation, orientations = _by_first_use(orientation, self.orientations.values)
        return SphereArrays(numbers[:, :3].copy(), numbers[:, 3].copy(), material, materials, line,
                            orientation, orientations)

    def attributes(self, args: list[str]) -> dict:
        """The sphere attributes after the radius, checked and converted."""
        values: dict = {}
        i = 0
        while i < len(args):
            token = args[i]
            name = token.lower()
            if isinstance(token, Quoted):
                self.fail(f"expected a sphere attribute name, got the quoted text {_show(token)}")
            if name not in ATTRIBUTES:
                if _NUMBER.fullmatch(token):
                    self.fail(f"expected a sphere attribute name, got the number {token}; "
                              f"attributes are {', '.join(ATTRIBUTES)}")
                self.fail(f"unknown sphere attribute {_show(token)}{suggest(token, ATTRIBUTES)}")
            if name in values:
                self.fail(f"sphere attribute {name} given twice")
            names = ATTRIBUTES[name]
            given = args[i + 1:i + 1 + len(names)]
            # Stop at the next attribute name so the message counts what was given.
            for k, value in enumerate(given):
                if not isinstance(value, Quoted) and value.lower() in ATTRIBUTES and name != "texture":
                    given = given[:k]
                    break
            if len(given) < len(names):
                self.fail(f"sphere {name} takes {len(names)} "
                          f"{'value' if len(names) == 1 else 'values'} ({' '.join(names)}), "
                          f"got {len(given)}")
            if name in ("north", "equator"):
                values[name] = self.part(self.vector, given, f"sphere {name}")
            else:
                values[name] = self.part(getattr(self, f"attribute_{name}"), given)
            i += 1 + len(names)
        return values

    def attribute_color(self, args):
        return self.color(args, "sphere color", 1)

    def attribute_reflect(self, args):
        return (self.bounded(args[0], "sphere reflect", 0, 1),)

    def attribute_refract(self, args):
        kt = self.bounded(args[0], "sphere refract KT", 0, 1)
        ior = self.number(args[1], "sphere refract IOR")
        self.positive(ior, args[1], "sphere refract IOR")
        return kt, ior

    def attribute_texture(self, args) -> Path:
        token = args[0]
        if not token:
            self.fail("sphere texture path is empty")
        if any(ord(c) < 32 or ord(c) == 127 for c in token):
            self.fail(f"sphere texture path {_show(token)} holds a control character")
        path = Path(os.path.abspath(self.source.parent / token))
        try:
            str(path).encode("utf-8")
        except UnicodeEncodeError:
            self.fail(f"sphere texture path {path} is not valid UTF-8")
        if path not in self._images:   # why Mitsuba could not use it, once per file
            self._images[path] = image_problem(path)
        problem = self._images[path]
        if problem:
            self.fail(f"sphere texture {_show(token)}: {problem}")
        return path

    def check_camera(self) -> None:
        scene, seen = self.scene, self.seen
        view = tuple(b - a for a, b in zip(scene.eye, scene.lookat))
        self.line = max(seen.get("eye", 0), seen.get("lookat", 0))
        if _is_zero(view):
            self.fail(f"eye and lookat must differ, both are {_show_vec(scene.eye)}")
        if sum(c * c for c in view) < 1e-300:  # Mitsuba's look_at would divide by zero
            self.fail(f"eye and lookat are too close together to give a direction "
                      f"({_show_vec(scene.eye)} and {_show_vec(scene.lookat)})")
        if _sine(view, scene.up) < PARALLEL_SINE:
            self.line = seen.get("up") or self.line
            default = "" if "up" in seen else " (the default)"
            self.fail(f"up {_show_vec(scene.up)}{default} must not be parallel to the viewing "
                      f"direction (from eye {_show_vec(scene.eye)} to lookat {_show_vec(scene.lookat)})")


def _float_or_nan(token: str) -> float:
    try:
        return float(token)
    except ValueError:
        return math.nan


def _by_first_use(index: np.ndarray, values: list) -> tuple[np.ndarray, tuple]:
    """``index`` renumbered so that its values come in order of first use, and those values."""
    import numpy as np
    distinct, first = np.unique(index, return_index=True)
    order = distinct[np.argsort(first)]
    if len(order) == len(values) and (order == np.arange(len(values))).all():
        return index, tuple(values)
    remap = np.zeros(len(values), np.int64)
    remap[order] = np.arange(len(order))
    return remap[index], tuple(values[k] for k in order.tolist())


def _floats(values) -> Vec3:
    return tuple(float(v) for v in values)


def _is_zero(v) -> bool:
    return all(c == 0 for c in v)


def _sine(a, b) -> float:
    """Sine of the angle between two directions (0 when either is zero)."""
    if _is_zero(a) or _is_zero(b):
        return 0.0
    return length(cross(normalize(a), normalize(b)))


def _show_vec(v) -> str:
    return " ".join(f"{c:g}" for c in v)
