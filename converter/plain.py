"""The parser's fast path: plain ``light`` and ``sphere`` lines read with ``float`` and numpy.

Scenes of millions of spheres must read fast, and only valid input needs to: a text without
quotes, continuations or odd separators is read a megabyte at a time, its plain sphere lines
found and converted with numpy into arrays. A line is taken only when every number lies clearly
inside its range; every other line, and every doubt, goes to the one statement reader
(``_Parser.careful_line`` in converter/parser.py), which alone words the messages.
"""

from __future__ import annotations

import math
import re
from decimal import Decimal

from .. import defaults
from .scene import Light, Material

LINE_BREAK = re.compile(r"\r\n|\r|\n")

# A text without these (quotes, continuations, NUL, separators the format does not know)
# splits into the careful tokenizer's tokens with str.split().
NOT_PLAIN_CHARACTERS = ('"', "\\", "\x00", "\x1c", "\x1d", "\x1e", "\x1f")
NOT_PLAIN_BYTES = tuple(c.encode() for c in NOT_PLAIN_CHARACTERS)
#: the bytes :meth:`PlainReader.read_bytes` reads at a time (a chunk ends at a line break)
_CHUNK = 1 << 20
_MAX = float(defaults.MAX_MAGNITUDE)        # |x| < this: inside the magnitude limit
_MIN = float(defaults.MIN_POSITIVE)         # x > this: at least MIN_POSITIVE
_BELOW_ONE = 1.0 - 1e-12                    # reflect + refract clearly <= 1
_WHITE = (1.0, 1.0, 1.0)
_PLAIN = Material(_WHITE, 0.0, 0.0, 1.0, None)   # a sphere without attributes

#: the control characters that are blanks or line breaks (the format's and str.split's alike)
_BLANK_CODES = (9, 10, 11, 12, 13)


def comment_text(text: str) -> str | None:
    """A statement's comment as the scene keeps it: the text after its ``#``, stripped, or None."""
    return text.strip() or None


def _float_or_nan(token: bytes) -> float:
    try:
        return float(token)
    except ValueError:
        return math.nan


class PlainReader:
    """Reads plain lines into the ``scene`` and ``spheres`` of ``reader`` (the parser's
    ``_Parser``), handing every other line to its ``careful_line(number, line)``."""

    def __init__(self, reader):
        self.reader = reader
        self.scene = reader.scene
        self.spheres = reader.spheres
        self.exact: set[str] = set()          # tokens exactly 0 or 1
        self._tails: dict[bytes, int] = {}    # attribute bytes -> material index, or -1

    def read_bytes(self, data: bytes) -> None:
        """Parse the UTF-8 bytes of a plain text, a chunk at a time (:meth:`read_chunk`)."""
        is_ascii = data.isascii()
        pos, line, n = 0, 1, len(data)
        while pos < n:
            end = data.find(b"\n", pos + _CHUNK) + 1 if pos + _CHUNK < n else n
            end = end or n
            line = self.read_chunk(data, pos, end, line, is_ascii)
            pos = end

    def read_chunk(self, data: bytes, pos: int, end: int, first: int, is_ascii: bool) -> int:
        """Parse the whole lines of ``data[pos:end]`` (the first is line ``first``); return the
        number of the line after them. Plain sphere lines are taken, the rest go to
        :meth:`read_line`."""
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
            commented, first_hash = np.unique(np.searchsorted(ends, hashes, "right"), return_index=True)
            code_end = ends.copy()
            code_end[commented] = hashes[first_hash]
            edges = np.zeros(m + 1, np.int8)
            edges[hashes[first_hash]] = 1
            edges[ends[commented]] -= 1
            sep |= np.cumsum(edges[:m], dtype=np.int8).view(bool)
        # lines whose code holds what str.split and float() read otherwise: non-ASCII bytes,
        # '_' or a control character that is no blank
        blank_codes = np.array(_BLANK_CODES, np.uint8)
        odd_control = np.isin(b[ctrl], blank_codes, invert=True).any()
        doubtful = np.zeros(lines, bool)
        if not is_ascii or odd_control or data.find(b"_", pos, end) >= 0:
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
            accepted[candidates] = self.chunk_spheres(data, pos, b, candidates + first, keyword,
                                                      counts[candidates], token_start, token_end)
            if hashes is not None:   # the comments of the spheres taken
                taken = commented[accepted[commented]]
                for k, a, z in zip(taken.tolist(), code_end[taken].tolist(), ends[taken].tolist()):
                    self.comment(first + k, data[pos + a + 1:pos + z].decode("utf-8", "surrogatepass"))
        rest = np.flatnonzero(((counts > 0) | doubtful) & ~accepted)
        for k, a, z in zip(rest.tolist(), starts[rest].tolist(), ends[rest].tolist()):
            self.read_line(first + k, data[pos + a:pos + z].decode("utf-8", "surrogatepass"))
        return first + breaks

    def chunk_spheres(self, data, pos, b, lines, keyword, counts, token_start, token_end) -> np.ndarray:
        """Add the spheres of the sphere lines ``lines`` (their keywords' token indices
        ``keyword``, their token ``counts``); return which were taken."""
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
                    material[group] = self.tail_material(rows[0].tobytes())
                else:
                    texts, which = np.unique(rows.view(f"S{length}").ravel(), return_inverse=True)
                    material[group] = np.array([self.tail_material(t) for t in texts.tolist()])[which]
            ok &= material >= 0
        if ok.all():
            self.spheres.add_arrays(lines, numbers[:, :3], radius, material)
        else:
            self.spheres.add_arrays(lines[ok], numbers[ok, :3], radius[ok], material[ok])
        return ok

    def tail_material(self, text: bytes) -> int:
        """The material index of a sphere's attributes ``text``, or -1 when not plain."""
        index = self._tails.get(text)
        if index is None:
            found = self.material(text.decode("ascii").split())
            index = self._tails[text] = -1 if found is None else self.spheres.material(found)
        return index

    def read_line(self, number: int, line: str) -> None:
        """A line that is not a plain sphere: a plain light (:meth:`light`), else the careful way."""
        comment_at = line.find("#")
        code = line if comment_at < 0 else line[:comment_at]
        tokens = code.split()
        if not tokens:
            if not code.isascii():  # blanks the format does not know may be tokens
                self.reader.careful_line(number, line)
            return
        # float() reads exactly the format's numbers in ASCII without '_' (nan/inf fail the ranges)
        if code.isascii() and "_" not in code and tokens[0].lower() == "light" and self.light(number, tokens):
            if comment_at >= 0:
                self.comment(number, line[comment_at + 1:])
            return
        self.reader.careful_line(number, line)

    def comment(self, number: int, text: str) -> None:
        text = comment_text(text)
        if text:
            self.scene.comments[number] = text

    def within(self, token: str, value: float, high: float = 1.0) -> bool:
        """Whether ``token`` (read as ``value``) lies clearly in [0, ``high``]: at a bound the
        text may lie a little beyond it ("1.00000000000000001"); exact ones are remembered."""
        if 0.0 < value < high or token in self.exact:
            return True
        if (value == 0.0 or value == high) and Decimal(token) == Decimal(value):
            self.exact.add(token)
            return True
        return False

    def light(self, line: int, tokens: list[str]) -> bool:
        """Add ``light X Y Z [R G B]`` and return True, or False to leave it to the reader."""
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
            if not all(c < _MAX and self.within(t, c, _MAX) for c, t in zip(color, tokens[4:])):
                return False
        self.scene.lights.append(Light(position, color, line=line))
        return True

    def material(self, tokens: list[str]) -> Material | None:
        """The material of the attributes ``[color R G B] [reflect KR] [refract KT IOR]``
        in any order, or None when they are anything else or not clearly valid."""
        color = kr = kt = None
        ior = 1.0
        i, n = 0, len(tokens)
        try:
            while i < n:
                name = tokens[i].lower()
                if name == "color" and color is None and i + 3 < n:
                    color = tuple(map(float, tokens[i + 1:i + 4]))
                    if not all(map(self.within, tokens[i + 1:i + 4], color)):
                        return None
                    i += 4
                elif name == "reflect" and kr is None and i + 1 < n:
                    kr = float(tokens[i + 1])
                    if not self.within(tokens[i + 1], kr):
                        return None
                    i += 2
                elif name == "refract" and kt is None and i + 2 < n:
                    kt, ior = float(tokens[i + 1]), float(tokens[i + 2])
                    if not self.within(tokens[i + 1], kt):
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
