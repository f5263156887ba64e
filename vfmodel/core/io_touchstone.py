"""Touchstone reader (version 1.x parsed here; version 2.x through scikit-rf).

Why not scikit-rf for version 1 files: scikit-rf 1.x-2.x multiplies Y (and G, H) data by
the reference resistance R like Z data, while Touchstone 1.x stores Z normalised as Z/R
and Y normalised as Y*R (so the true Y is the stored value divided by R: a factor R^2
wrong); it takes a 2-port row whose frequency decreases for the start of a noise block even
when the row has the 9 numbers of a network row (silently dropping the rest of the file);
and it reads the option line by position, while the fields may come in any order
(``# MHz MA S R 50`` is legal).

Version 1.x rules implemented: ``!`` starts a comment anywhere on a line; the first option
line (``# [Hz|kHz|MHz|GHz] [S|Y|Z|G|H] [DB|MA|RI] [R n]``, fields in any order, each at
most once, defaults ``GHz S MA R 50``) counts, later ones are ignored; a row is the
frequency and 2N^2 numbers (2-port: N11 N21 N12 N22; other N row by row, wrapped over
lines); frequencies increase strictly; a 2-port file may end in a noise block (rows of 5
numbers starting at a frequency not above the last network frequency), which is skipped.
"""

from __future__ import annotations

import io
import math
import re
import warnings
from array import array
from pathlib import Path

import numpy as np

from vfmodel._choices import Kind
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.errors import InputError, VfmodelWarning

_UNITS = {"HZ": 1.0, "KHZ": 1e3, "MHZ": 1e6, "GHZ": 1e9}
_PARAMS = ("S", "Y", "Z", "G", "H")
_FORMATS = ("DB", "MA", "RI")


# Touchstone 1.1 requires the option line (its fields default, the line does not); some
# readers (scikit-rf) then assume the fields' defaults, which the message offers
_NO_OPTION = ("an option line like '# Hz S RI R 50' before the data (Touchstone requires "
              "one; '# GHz S MA R 50' states the defaults of its fields, which some readers "
              "assume for a file without it)")


class OptionLine:
    """The parsed option line: frequency multiplier, parameter, format, R."""

    def __init__(self, unit: str = "GHZ", param: str = "S", fmt: str = "MA",
                 r_ohm: float = 50.0) -> None:
        self.unit, self.param, self.fmt, self.r_ohm = unit, param, fmt, r_ohm
        # Touchstone 1.1 (and scikit-rf) allow one R per port: all of them when more
        # than one is given
        self.r_ports: tuple[float, ...] = ()

    @property
    def mult(self) -> float:
        return _UNITS[self.unit]

    @property
    def per_port(self) -> bool:
        """Different reference resistances per port (``R 50 50 100``)."""
        return len(set(self.r_ports)) > 1

    def canonical(self) -> str:
        rs = self.r_ports or (self.r_ohm,)
        return f"# {self.unit} {self.param} {self.fmt} R " + " ".join(f"{r:.17g}" for r in rs)


def parse_option_line(line: str, src: str, place: str) -> OptionLine:
    """Parse ``# ...`` (comment already removed); fields in any order, each at most once."""
    opt = OptionLine()
    seen: set[str] = set()
    toks = line.strip()[1:].split()
    k = 0
    while k < len(toks):
        tok = toks[k].upper()
        if tok in _UNITS:
            field, opt.unit = "frequency unit", tok
        elif tok in _PARAMS:
            field, opt.param = "parameter", tok
        elif tok in _FORMATS:
            field, opt.fmt = "format", tok
        elif tok == "R":
            field = "R"
            if k + 1 >= len(toks):
                raise InputError("option line: R without a value", source=src, place=place,
                                 expected="'R <ohms>'")
            k += 1
            try:
                r = float(toks[k])
            except ValueError:
                raise InputError("option line: bad reference resistance", source=src,
                                 place=place, found=repr(toks[k][:20]),
                                 expected="a positive number of ohms") from None
            if not (math.isfinite(r) and r > 0):
                raise InputError("option line: bad reference resistance", source=src,
                                 place=place, found=toks[k][:20],
                                 expected="a positive number of ohms")
            opt.r_ohm = r
            more = [r]
            while k + 1 < len(toks) and _is_float(toks[k + 1]):  # one R per port (1.1)
                k += 1
                more.append(float(toks[k]))
                if not (math.isfinite(more[-1]) and more[-1] > 0):
                    raise InputError("option line: bad reference resistance", source=src,
                                     place=place, found=toks[k][:20],
                                     expected="a positive number of ohms")
            opt.r_ports = tuple(more) if len(more) > 1 else ()
        else:
            raise InputError("option line: unknown field", source=src, place=place,
                             found=repr(toks[k][:20]),
                             expected="Hz/kHz/MHz/GHz, S/Y/Z/G/H, DB/MA/RI and 'R <ohms>' "
                             "(or one R per port)")
        if field in seen:
            raise InputError(f"option line: {field} given twice", source=src, place=place)
        seen.add(field)
        k += 1
    return opt


def read_touchstone_text(text: str, n_ports: int | None, src: str) -> FrequencyData:
    """Read Touchstone ``text`` (``n_ports`` from the ``.sNp`` suffix; None for ``.ts``)."""
    lines = text.splitlines()
    for raw in lines:
        s = raw.split("!", 1)[0].strip()
        if not s:
            continue
        if s.lower().startswith("[version]"):
            return _read_v2(text, src)
        break
    if n_ports is None:
        raise InputError("a '.ts' file must be Touchstone 2 (a '[Version] 2.0' first line)",
                         source=src, expected="'[Version] 2.0' or a '.sNp' file name")
    return _read_v1(lines, n_ports, src)


def _read_v1(lines: list[str], n: int, src: str) -> FrequencyData:
    opt: OptionLine | None = None
    per_row = 1 + 2 * n * n
    data = array("d")
    cur = 0                       # numbers of the current row read so far
    prev_f: float | None = None
    noise_from: int | None = None
    for lineno, raw in enumerate(lines, start=1):
        s = raw.split("!", 1)[0].strip()
        if not s:
            continue
        place = f"line {lineno}"
        if s.startswith("#"):
            if opt is None:
                opt = parse_option_line(s, src, place)
            continue
        if s.startswith("["):
            raise InputError("Touchstone 2 keyword in a Touchstone 1 file", source=src,
                             place=place, expected="'[Version] 2.0' as the first keyword")
        if opt is None:
            raise InputError("no Touchstone option line before the data", source=src,
                             place=place, expected=_NO_OPTION)
        try:
            vals = [float(t) for t in s.split()]
        except ValueError:
            bad = next(t for t in s.split() if not _is_float(t))
            raise InputError("not a number", source=src, place=place,
                             found=repr(bad[:20])) from None
        if not all(math.isfinite(v) for v in vals):
            raise InputError("value is NaN or infinite", source=src, place=place,
                             expected="finite numbers")
        if noise_from is not None:
            if len(vals) != 5:
                raise InputError("noise-parameter row must have 5 numbers", source=src,
                                 place=place, found=str(len(vals)),
                                 expected="frequency, NFmin, |Gamma_opt|, angle, Rn/R0")
            continue
        if cur == 0:
            f = vals[0]
            if prev_f is not None and f <= prev_f:
                if n == 2 and len(vals) == 5:
                    noise_from = lineno
                    continue
                raise InputError(
                    "decreasing frequency or repeated frequency", source=src, place=place,
                    found=f"{f:.9g} after {prev_f:.9g}",
                    expected=f"strictly increasing frequencies ({per_row} numbers per row"
                    + ("; a noise block has rows of 5 numbers)" if n == 2 else ")"))
            if f < 0:
                raise InputError("negative frequency", source=src, place=place,
                                 found=f"{f:.9g}")
        cur += len(vals)
        if cur > per_row:
            raise InputError(f"wrong number of values for a {n}-port row", source=src,
                             place=place, found=f"{cur} numbers in the row",
                             expected=f"{per_row} (frequency and {n * n} complex values)")
        data.extend(vals)
        if cur == per_row:
            prev_f = data[-per_row]
            cur = 0
    if opt is None:
        raise InputError("no Touchstone option line", source=src, expected=_NO_OPTION)
    if opt.r_ports and len(opt.r_ports) != n:
        raise InputError("option line: one R per port or one R for all", source=src,
                         found=f"{len(opt.r_ports)} values after R",
                         expected=f"1 or {n} (the file's ports)")
    if cur != 0:
        raise InputError(f"last row incomplete for a {n}-port file", source=src,
                         found=f"{cur} numbers", expected=f"{per_row}")
    if len(data) == 0:
        raise InputError("Touchstone file has no data points", source=src)
    if opt.per_port or _hfss_references_differ(lines, opt.r_ohm, n, len(data) // per_row, src):
        # references per port or per frequency (HFSS's "! Port Impedance" comments): read
        # by scikit-rf, which knows their wave definitions, then renormalised to a common
        # reference (FrequencyData.from_network, with a warning)
        return _read_with_skrf(_canonical_text(lines, opt), opt, f"data.s{n}p", src)
    table = np.frombuffer(data, dtype=float).reshape(-1, per_row)
    a, b = table[:, 1::2], table[:, 2::2]
    with np.errstate(over="ignore", invalid="ignore"):  # overflow refused in _to_data
        if opt.fmt == "RI":
            flat = a + 1j * b
        else:
            mag = 10.0 ** (a / 20.0) if opt.fmt == "DB" else a
            flat = mag * np.exp(1j * np.deg2rad(b))
    values = flat.reshape(-1, n, n)
    if n == 2:
        values = values.transpose(0, 2, 1)  # N11 N21 N12 N22: column by column
    return _to_data(table[:, 0] * opt.mult, values, opt, src)


def _is_float(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


def _to_data(freq: np.ndarray, values: np.ndarray, opt: OptionLine, src: str,
             normalised: bool = True) -> FrequencyData:
    if opt.param not in ("S", "Y", "Z"):
        raise InputError("unsupported Touchstone parameter type", source=src,
                         found=opt.param, expected="S, Y or Z")
    kind: Kind = opt.param  # type: ignore[assignment]
    with np.errstate(over="ignore", invalid="ignore"):
        if kind == "Z" and normalised:
            values = values * opt.r_ohm           # stored z = Z / R
        elif kind == "Y" and normalised:
            values = values / opt.r_ohm           # stored y = Y * R
    if not np.all(np.isfinite(values)):
        raise InputError("Touchstone values overflow", source=src,
                         expected="magnitudes (or dB values) that fit a float")
    return FrequencyData(freq, values, kind=kind, z0=opt.r_ohm if kind == "S" else None,
                         source=src)


def _read_v2(text: str, src: str) -> FrequencyData:
    """Touchstone 2.x through scikit-rf (option line made canonical first; Z/Y data of
    version 2 are not normalised)."""
    lines = text.splitlines()
    opt: OptionLine | None = None
    for k, raw in enumerate(lines, start=1):
        s = raw.split("!", 1)[0].strip()
        if s.startswith("#"):
            opt = parse_option_line(s, src, f"line {k}")
            break
    _check_reference(text, src)
    if opt is None:
        return _read_with_skrf(text, OptionLine(), _v2_name(src), src)
    return _read_with_skrf(_canonical_text(lines, opt), opt, _v2_name(src), src)


def _v2_name(src: str) -> str:
    """The name scikit-rf sees for Touchstone 2 text: a '.ts' file keeps its own."""
    return Path(src).name if Path(src).suffix.lower() == ".ts" else "data.ts"


def _canonical_text(lines: list[str], opt: OptionLine) -> str:
    """The lines with the (first) option line written in scikit-rf's field order."""
    out, done = [], False
    for raw in lines:
        if not done and raw.split("!", 1)[0].strip().startswith("#"):
            out.append(opt.canonical())
            done = True
        else:
            out.append(raw)
    return "\n".join(out)


_HFSS_Z0 = re.compile(r"^\s*!\s*port\s+impedance", re.IGNORECASE)


def _hfss_references_differ(lines: list[str], r_ohm: float, n: int, n_rows: int,
                            src: str) -> bool:
    """True when an HFSS export's ``! Port Impedance`` comments (real and imaginary part
    per port, or a full n x n matrix, one block per frequency) give references other than
    the option line's R (scikit-rf's files write 50 0 there for R 50; TouchstoneParser.jl's
    spiral inductor the matrix 50 0 0 0 0 0 50 0) or are wrapped over continuation lines:
    scikit-rf then reads them. Blocks that scikit-rf cannot read (it failed with a
    ValueError or an AttributeError) are refused here with the line: a port impedance
    that is not finite or has no positive real part, an odd count without continuation,
    a block count other than the number of frequencies."""
    differ, blocks = False, 0

    def refuse(why: str, k: int, expected: str) -> InputError:
        return InputError(f"HFSS port impedance comment: {why}", source=src,
                          place=f"line {k}", found=lines[k - 1].strip()[:80],
                          expected=expected)

    for k, raw in enumerate(lines, start=1):
        m = _HFSS_Z0.match(raw)
        if m is None:
            continue
        blocks += 1
        vals = [float(t) for t in raw[m.end():].split() if _is_float(t)]
        if len(vals) % 2:
            nxt = lines[k].split("!", 1) if k < len(lines) else [""]
            if nxt[0].strip() or len(nxt) < 2 or not nxt[1].split() \
                    or not all(_is_float(t) for t in nxt[1].split()):
                raise refuse("an odd count of numbers", k,
                             "real and imaginary part per port (or per matrix entry)")
            differ = True  # wrapped: scikit-rf joins the lines
            continue
        z = np.asarray(vals[0::2], dtype=float) + 1j * np.asarray(vals[1::2], dtype=float)
        off = np.zeros(0, dtype=complex)
        if z.size == n * n and n > 1:  # a matrix: the ports' values on the diagonal
            off = z.reshape(n, n)[~np.eye(n, dtype=bool)]
            z = np.diag(z.reshape(n, n))
        if not (np.all(np.isfinite(z)) and np.all(z.real > 0)):
            raise refuse("a port impedance that is not finite or has no positive real part",
                         k, "real and imaginary part per port, real part > 0")
        differ = differ or bool(np.any(off != 0)) or \
            not bool(np.all(np.abs(z - r_ohm) <= 1e-12 * r_ohm))
    if differ and blocks != n_rows:
        raise InputError("HFSS port impedance comments: one block per frequency expected",
                         source=src, found=f"{blocks} blocks for {n_rows} frequencies",
                         expected=f"{n_rows} '! Port Impedance' blocks")
    return differ


def _read_with_skrf(text: str, opt: OptionLine, name: str, src: str) -> FrequencyData:
    """Touchstone ``text`` (option line canonical) read by scikit-rf as ``name`` (its
    suffix tells the version and ports), as ``opt.param`` data."""
    import skrf
    from skrf.io.touchstone import Touchstone

    if opt.param not in ("S", "Y", "Z"):
        raise InputError("unsupported Touchstone parameter type", source=src,
                         found=opt.param, expected="S, Y or Z")
    fid = io.StringIO(text + "\n")
    fid.name = name
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            ts = Touchstone(fid)
            net = skrf.Network(frequency=skrf.Frequency.from_f(ts.f, unit="hz"), s=ts.s,
                               z0=ts.z0, s_def=ts.s_def or "power")
    except InputError:
        raise
    except Exception as err:  # scikit-rf raises many types on malformed files
        raise InputError(f"not a readable Touchstone file ({type(err).__name__})",
                         source=src) from None
    if net.f.size == 0:
        raise InputError("Touchstone file has no data points", source=src)
    if np.any(np.diff(net.f) <= 0):
        k = int(np.argmax(np.diff(net.f) <= 0))
        raise InputError("frequencies do not increase", source=src,
                         place=f"data row {k + 2}", expected="strictly increasing")
    if not np.all(np.isfinite(net.s)):
        raise InputError("Touchstone data are not finite after conversion", source=src)
    kind: Kind = opt.param  # type: ignore[assignment]
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            fd = FrequencyData.from_network(net, kind=kind, source=src)
    except np.linalg.LinAlgError as err:
        raise InputError(f"cannot convert the Touchstone data to {kind} parameters ({err})",
                         source=src) from None
    for w in caught:  # scikit-rf's conversion warnings stay silent, vfmodel's are passed on
        if issubclass(w.category, VfmodelWarning):
            warnings.warn(w.message, w.category, stacklevel=2)
    return fd


def _check_reference(text: str, src: str) -> None:
    """The ``[Reference]`` keyword holds one number per port, on its line and the lines
    after it up to the next keyword (scikit-rf reads on past the keyword: with one value
    for a 2-port it took the first frequency of ``[Network Data]`` as port 2's reference
    and dropped that row; with three, it ignored the third)."""
    ports: int | None = None
    ref: list[str] | None = None
    for k, raw in enumerate(text.splitlines(), start=1):
        s = raw.split("!", 1)[0].strip()
        low = s.lower()
        if low.startswith("[number of ports]"):
            try:
                ports = int(s.split("]", 1)[1])
            except ValueError:
                return  # scikit-rf's reader reports it
        if ref is not None:
            if s.startswith("[") or s.startswith("#"):
                break
            ref += s.split()
        elif low.startswith("[reference]"):
            ref, place = s.split("]", 1)[1].split(), f"line {k}"
    if ref is None or ports is None:
        return
    try:
        vals = [float(t) for t in ref]
    except ValueError:
        vals = []
    if len(vals) != ports or len(ref) != ports:
        raise InputError("[Reference] must give one reference impedance per port",
                         source=src, place=place, found=" ".join(ref) or "nothing",
                         expected=f"{ports} numbers (ohm)")


_SUFFIX_RE = re.compile(r"^\.s(\d+)p$", re.IGNORECASE)


def ports_from_suffix(path: Path) -> int | None:
    """N of a ``.sNp`` suffix, None for ``.ts``."""
    m = _SUFFIX_RE.match(path.suffix)
    return int(m.group(1)) if m else None
