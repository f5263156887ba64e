"""Generated malformed CSV, Touchstone and TOML inputs: readers either return valid data
or raise the documented InputError, never any other exception (hypothesis, 3 x 100 cases)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_dataset import read_dataset
from vfmodel.core.io_spectrum import read_spectrum
from vfmodel.errors import InputError

VALID_CSV = (
    "frequency_hz,z_real_ohm,z_imag_ohm\n1000,5.0,-3.2\n2000,5.1,-1.1\n4000,5.3,2.5\n"
)
VALID_TS = "! test\n# Hz Z RI R 50\n1000 0.1 -0.064\n2000 0.102 -0.022\n4000 0.106 0.05\n"
VALID_TOML = (
    'name = "x"\ntemperature_c = 80.0\n[impedance]\n"U-Frame" = "z.csv"\n'
)

_noise_chars = st.sampled_from(list(",.-+eE#!\n\r\t []=\"'0123456789nainfNAINFxyz\x00\xff"))


@st.composite
def mutated(draw: st.DrawFn, base: str) -> bytes:
    """Apply 1-6 random edits (delete, insert, replace, duplicate line, truncate)."""
    text = base
    for _ in range(draw(st.integers(1, 6))):
        op = draw(st.sampled_from(["del", "ins", "rep", "dup", "trunc", "swap"]))
        n = len(text)
        if n == 0:
            break
        i = draw(st.integers(0, n - 1))
        if op == "del":
            j = draw(st.integers(i, min(n, i + 8)))
            text = text[:i] + text[j:]
        elif op == "ins":
            text = text[:i] + draw(st.text(_noise_chars, min_size=1, max_size=6)) + text[i:]
        elif op == "rep":
            text = text[:i] + draw(_noise_chars) + text[i + 1 :]
        elif op == "dup":
            lines = text.splitlines(keepends=True)
            k = draw(st.integers(0, len(lines) - 1))
            lines.insert(k, lines[k])
            text = "".join(lines)
        elif op == "trunc":
            text = text[:i]
        else:
            lines = text.splitlines(keepends=True)
            if len(lines) > 2:
                k = draw(st.integers(1, len(lines) - 2))
                lines[k], lines[k + 1] = lines[k + 1], lines[k]
                text = "".join(lines)
    raw = text.encode("utf-8", errors="surrogatepass")
    if draw(st.booleans()) and draw(st.integers(0, 9)) == 0:
        raw = draw(st.binary(min_size=0, max_size=200))
    return raw


def _accept(fn: object, path: Path) -> None:
    try:
        out = fn(path)  # type: ignore[operator]
    except InputError as err:
        assert str(path) in str(err) or path.name in str(err)
        return
    if isinstance(out, FrequencyData):
        assert np.all(np.isfinite(out.values)) and np.all(np.diff(out.freq_hz) > 0)


_settings = settings(max_examples=100, deadline=None, derandomize=True,
                     suppress_health_check=[HealthCheck.too_slow])


@_settings
@given(mutated(VALID_CSV))
def test_fuzz_csv(raw: bytes) -> None:
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "z.csv"
        p.write_bytes(raw)
        _accept(read_spectrum, p)


@_settings
@given(mutated(VALID_TS))
def test_fuzz_touchstone(raw: bytes) -> None:
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "z.s1p"
        p.write_bytes(raw)
        _accept(read_spectrum, p)


@_settings
@given(mutated(VALID_TOML))
def test_fuzz_dataset_toml(raw: bytes) -> None:
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "z.csv").write_text(VALID_CSV)
        p = Path(d) / "dataset.toml"
        p.write_bytes(raw)
        try:
            read_dataset(d)
        except InputError as err:
            assert d in str(err)
