"""The legacy ``.scn`` text -> :class:`Scene`, checking every rule of the scene format
(``docs/scene-format.md``, "Syntax" and "Errors").

A file is accepted as a whole or rejected with one :class:`SceneError` that lists every
problem in it, so that nothing invalid reaches Mitsuba and a user fixes a file in one go.
Large scenes are read on the fast path of :mod:`.plain`, which hands every other line, and
every doubt, to the one statement reader here (:meth:`_Parser.careful_line`).
"""

from __future__ import annotations

import difflib
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
from .textures import image_problem
from .plain import LINE_BREAK, NOT_PLAIN_BYTES, NOT_PLAIN_CHARACTERS, PlainReader, comment_text
from .scene import Distinct, Light, Material, Scene, Sphere, SphereArrays, Vec3, first_use
from .scene import cross, length, normalize

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
_BLANKS = " \t\f\v"
#: a sphere's (north, equator) when its statement gives neither (the fast path's spheres')
_DEFAULT_ORIENTATION = (defaults.NORTH, defaults.EQUATOR)


def parse_file(path: str | os.PathLike) -> Scene:
    """Read and parse a ``.scn`` file; errors name ``path`` as given."""
    path = Path(path)
    data = read_scene_file(path)
    if data.isascii() and not any(c in data for c in NOT_PLAIN_BYTES):
        # the fast path straight from the bytes: ASCII is UTF-8 without a BOM
        parser = _Parser(path)
        PlainReader(parser).read_bytes(data)
        return parser.finish()
    return parse_text(decode(data, path), path)


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
    return text[1:] if text.startswith("\ufeff") else text


def _line_of(data: bytes, offset: int) -> int:
    """1-based line of byte ``offset``; the bytes before it may be any encoding."""
    head = data[:offset].decode("utf-8", errors="replace")
    return len(LINE_BREAK.findall(head)) + 1


@dataclass(frozen=True)
class Token:
    text: str
    quoted: bool = False

    def show(self) -> str:
        """The token as written, quoted and safe for a one-line message."""
        return repr(_clip(self.text))


def _clip(text: str) -> str:
    return text if len(text) <= 40 else text[:37] + "..."


def _statements(text: str, path, errors: list, comments: dict) -> list[tuple[int, list[Token]]]:
    """Split ``text`` into statements: (first line number, tokens); a statement's comment
    goes into ``comments`` by that line, the problem of one that cannot be split into
    ``errors`` as (line, message). The syntax: docs/scene-format.md, "Syntax"."""
    statements = []
    tokens: list[Token] = []
    first = 0
    remark = None   # the statement's comment
    skipping = False  # the continuation lines of a statement that could not be split
    lines = LINE_BREAK.split(text)
    if len(lines) > 1 and lines[-1] == "":
        lines.pop()  # the final line break ends the last line; no empty line follows it
    for number, line in enumerate(lines, start=1):
        if skipping:
            skipping = line.rstrip(_BLANKS).endswith("\\")
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
            statements.append((first, tokens))
            if remark:
                comments[first] = remark
        tokens = []
    return statements


def _split_line(line: str, path, first: int) -> tuple[list[Token], bool, str | None]:
    """Tokens of one physical line, whether it ends with a continuation ``\\``, its comment."""
    if "\0" in line:
        raise SceneError(path, first, "binary file (NUL character), not a text scene")
    tokens: list[Token] = []
    remark = None
    i, n = 0, len(line)
    while i < n:
        c = line[i]
        if c in _BLANKS:
            i += 1
        elif c == "#":
            remark = comment_text(line[i + 1:])
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
    return tokens, continued, remark


def parse_text(text: str, source: str | os.PathLike, *, careful: bool = False) -> Scene:
    """Parse scene text; ``source`` names the file in messages and anchors relative textures.
    ``careful=True``: every statement on the careful path (the parser's benchmark times both)."""
    source = Path(source)
    if text.startswith("\ufeff"):
        text = text[1:]
    parser = _Parser(source)
    if not careful and not any(c in text for c in NOT_PLAIN_CHARACTERS):
        PlainReader(parser).read_bytes(text.encode("utf-8", "surrogatepass"))
    else:
        for line, tokens in _statements(text, source, parser.errors, parser.scene.comments):
            parser.statement(line, tokens)
    return parser.finish()


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
        self.spheres = _SphereList()          # the spheres read so far
        self._alike: dict[tuple, tuple] = {}  # attribute texts -> (material, (north, equator))

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

    def color(self, args: list[Token], what: str, high=None):
        color = self.vector(args, what)
        for value, token in zip(color, args):
            self.in_range(value, token.text, what, 0, high)
        return color

    def bounded(self, token: Token, what: str, low, high, integer: bool = False) -> Decimal:
        value = self.number(token, what, integer=integer)
        self.in_range(value, token.text, what, low, high)
        return value

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

    def finish(self) -> Scene:
        """The scene once every statement is read, or every problem, in file order, as one
        :class:`SceneError`."""
        if not self.failed & {"eye", "lookat", "up"}:  # else the camera is not what the file says
            try:
                self.check_camera()
            except SceneError as error:
                self.errors.append((error.line, error.message))
        if self.errors:
            self.errors.sort(key=lambda error: error[0] or 0)
            raise SceneError.collected([(self.source, line, message) for line, message in self.errors],
                                      defaults.MAX_REPORTED_ERRORS)
        self.scene.spheres = self.spheres.arrays()
        self.scene.comments = dict(sorted(self.scene.comments.items()))   # by line, on every path
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

    def careful_line(self, number: int, line: str) -> None:
        """Read one physical line (the fast path's every doubt) the careful way."""
        tokens, _, remark = _split_line(line, self.source, number)
        if tokens:
            self.statement(number, tokens)
            if remark:
                self.scene.comments[number] = remark

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
        self.scene.background = _floats(self.color(args, "background color"))

    def _one_number(self, args, statement, placeholder, low, high, integer=False):
        self.count(statement, args, placeholder, 1)
        value = self.bounded(args[0], statement, low, high, integer)
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
        color = self.part(self.color, args[3:], "light color") if len(args) == 6 else (1, 1, 1)
        self.settle(errors)
        self.scene.lights.append(Light(_floats(position), _floats(color), line=self.line))

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
        for name, direction in (("north", north), ("equator", equator)):
            if _is_zero(direction):
                self.fail(f"sphere {name} must not be zero")
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
        # spheres written alike share these objects, which _SphereList numbers by identity
        given = "north" in values or "equator" in values
        material, orientation = self._alike.setdefault(
            tuple(t.text for t in args[4:]), (material, (north, equator) if given else _DEFAULT_ORIENTATION))
        self.spheres.add(self.line, _floats(center), float(radius), material, orientation)

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
        return self.color(args, "sphere color", 1)

    def attribute_reflect(self, args):
        return (self.bounded(args[0], "sphere reflect", 0, 1),)

    def attribute_refract(self, args):
        kt = self.bounded(args[0], "sphere refract KT", 0, 1)
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
        """Why Mitsuba could not use ``path`` as a texture, or None (cached)."""
        if path not in self._images:
            self._images[path] = image_problem(path)
        return self._images[path]

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


class _SphereList:
    """The spheres of a file as read: arrays (the fast path) and single ones, in file order."""

    def __init__(self):
        self.blocks: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.singles: list[tuple] = []   # (line, center, radius, material, (north, equator))
        self.materials = Distinct()

    def material(self, material: Material) -> int:
        return self.materials.index(material)

    def add(self, line: int, center: Vec3, radius: float, material: Material, orientation) -> None:
        """One sphere; ``orientation``: its ``(north, equator)``."""
        self.singles.append((line, center, radius, material, orientation))

    def add_arrays(self, lines, centers, radii, materials) -> None:
        """Spheres of the default orientation, their material indices from :meth:`material`."""
        if len(lines):
            self.blocks.append((lines, centers, radii, materials))

    def arrays(self) -> SphereArrays:
        import numpy as np
        blocks = list(self.blocks)
        orientations = Distinct()
        orientations.index(_DEFAULT_ORIENTATION)
        if self.singles:
            n = len(self.singles)
            lines, centers, radii, materials, pairs = zip(*self.singles)
            blocks.append((np.array(lines, np.int64), np.array(centers, np.float64).reshape(n, 3),
                           np.array(radii, np.float64), np.fromiter(map(self.material, materials), np.int64, n)))
            single_orientation = np.fromiter(map(orientations.index, pairs), np.int64, n)
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
    """``index`` renumbered so that its values come in order of first use, and those values."""
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
