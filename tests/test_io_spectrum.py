"""Spectrum files: round trips to 1e-9 and agreement with scikit-rf's reader."""

from __future__ import annotations

from pathlib import Path
from typing import cast

import numpy as np
import pytest
import skrf
from numpy.typing import NDArray

from tests.conftest import TOUCHSTONE_DIR, rlc_impedance
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_spectrum import read_spectrum, write_spectrum


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_csv_touchstone_csv_round_trip(tmp_path: Path) -> None:
    f = np.logspace(3, 7, 301)
    orig = FrequencyData(f, rlc_impedance(f), "Z")
    write_spectrum(tmp_path / "a.csv", orig)
    a = read_spectrum(tmp_path / "a.csv")
    write_spectrum(tmp_path / "b.s1p", a)
    b = read_spectrum(tmp_path / "b.s1p")
    write_spectrum(tmp_path / "c.csv", b)
    c = read_spectrum(tmp_path / "c.csv")
    assert c.kind == "Z"
    assert _rel(c.freq_hz, f) < 1e-12
    assert np.max(np.abs(c.values - orig.values) / np.abs(orig.values)) < 1e-9


@pytest.mark.parametrize("name", ["Agilent_E5071B.s4p", "cst_example_4ports.s4p"])
def test_touchstone_csv_touchstone_round_trip(tmp_path: Path, name: str) -> None:
    orig = read_spectrum(TOUCHSTONE_DIR / name)
    ref = skrf.Network(str(TOUCHSTONE_DIR / name))
    assert _rel(orig.values, ref.s) < 1e-15  # our reader returns what scikit-rf reads
    write_spectrum(tmp_path / "x.csv", orig)
    write_spectrum(tmp_path / "y.s4p", read_spectrum(tmp_path / "x.csv"))
    back = read_spectrum(tmp_path / "y.s4p")
    assert back.kind == "S" and back.z0 == orig.z0
    assert _rel(back.values, orig.values) < 1e-9
    assert _rel(back.freq_hz[1:], orig.freq_hz[1:]) < 1e-12


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_z_touchstone_read_back_by_scikit_rf(tmp_path: Path, n: int) -> None:
    rng = np.random.default_rng(n)
    z = rng.normal(size=(9, n, n)) + 1j * rng.normal(size=(9, n, n)) + 10 * np.eye(n)
    data = FrequencyData(np.linspace(1e3, 1e6, 9), cast(NDArray[np.complex128], z), "Z")
    path = tmp_path / f"z.s{n}p"
    write_spectrum(path, data)
    net = skrf.Network(str(path))
    assert _rel(net.z, z) < 1e-12
    assert _rel(read_spectrum(path).values, z) < 1e-12


def test_mag_phase_csv(tmp_path: Path) -> None:
    f = np.array([1e3, 1e4, 1e5])
    z = rlc_impedance(f)
    rows = "\n".join(
        f"{fi:.17g},{abs(zi):.17g},{np.degrees(np.angle(zi)):.17g}"
        for fi, zi in zip(f, z, strict=True)
    )
    (tmp_path / "m.csv").write_text("frequency_hz,z_mag_ohm,z_phase_deg\n" + rows + "\n")
    got = read_spectrum(tmp_path / "m.csv").values[:, 0, 0]
    assert np.max(np.abs(got - z) / np.abs(z)) < 1e-12


def test_generic_csv_h_data(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    h = rng.normal(size=(4, 1, 3)) + 1j * rng.normal(size=(4, 1, 3))
    d = FrequencyData(np.arange(1.0, 5.0), h, "H")
    write_spectrum(tmp_path / "h.csv", d)
    back = read_spectrum(tmp_path / "h.csv")
    assert back.kind == "H" and back.values.shape == (4, 1, 3)
    assert _rel(back.values, h) < 1e-15


# ---------------------------------------------------------------- issue 16 (1, 2), issue 13
def _cli(*argv: str) -> int:
    from vfmodel.cli.main import main

    return main(list(argv))


@pytest.mark.parametrize("n", [1, 2])
def test_touchstone_y_is_normalised_by_r(tmp_path: Path, n: int) -> None:
    """Touchstone 1.x stores y = Y*R: '# GHZ Y RI R 50' with 1+0.05j means Y = 0.02+0.001j S
    (scikit-rf 2.2 reads 50+2.5j, a factor R^2 = 2500 wrong)."""
    row = "1 1 0.05" if n == 1 else "1 1 0.05 0.1 0 0.2 0 2 0"  # N11 N21 N12 N22
    p = tmp_path / f"y.s{n}p"
    p.write_text(f"! external file\n# GHZ Y RI R 50\n{row}\n2 {row[2:]}\n")
    d = read_spectrum(p)
    assert d.kind == "Y"
    assert d.freq_hz.tolist() == [1e9, 2e9]
    assert abs(d.values[0, 0, 0] - (0.02 + 0.001j)) < 1e-15
    if n == 2:
        assert abs(d.values[0, 1, 0] - 0.002) < 1e-15   # N21 is the second pair
        assert abs(d.values[0, 0, 1] - 0.004) < 1e-15   # N12 the third
        assert abs(d.values[0, 1, 1] - 0.04) < 1e-15


def test_touchstone_z_is_normalised_by_r(tmp_path: Path) -> None:
    p = tmp_path / "z.s1p"
    p.write_text("# MHZ Z MA R 75\n1 2 90\n")    # z = 2 at 90 deg -> Z = 150j ohm
    d = read_spectrum(p)
    assert d.kind == "Z" and d.freq_hz[0] == 1e6
    assert abs(d.values[0, 0, 0] - 150j) < 1e-12


@pytest.mark.parametrize("kind,unit", [("Y", "S"), ("Z", "ohm")])
def test_y_z_convert_round_trip_and_file_values(tmp_path: Path, kind: str, unit: str) -> None:
    """convert y.csv y.s2p then y.s2p back.csv --kind Y: the same numbers, and the file
    holds the normalised values (Y*R or Z/R) a Touchstone 1 reader expects."""
    k = kind.lower()
    v = np.array([[0.02 + 0.001j, -0.001 + 0j], [-0.001 + 0j, 0.03 - 0.002j]])
    if kind == "Z":
        v = 1 / v
    head = "frequency_hz," + ",".join(f"{k}{i}_{j}_{p}" for i in (1, 2) for j in (1, 2)
                                       for p in ("real", "imag"))
    rows = [f"{f}," + ",".join(f"{x.real:.17g},{x.imag:.17g}" for x in (v * (1 + f / 1e7)).ravel())
            for f in (1e6, 2e6, 3e6)]
    src = tmp_path / "y.csv"
    src.write_text(head + "\n" + "\n".join(rows) + "\n")
    assert _cli("convert", str(src), str(tmp_path / "y.s2p")) == 0
    text = (tmp_path / "y.s2p").read_text()
    assert f"# Hz {kind} RI R 50" in text
    first = [float(x) for x in text.splitlines()[2].split()]
    norm = v[0, 0] * 1.1 * (50 if kind == "Y" else 1 / 50)
    assert abs(complex(first[1], first[2]) - norm) < 1e-12 * abs(norm)
    assert _cli("convert", str(tmp_path / "y.s2p"), str(tmp_path / "back.csv"),
                "--kind", kind) == 0
    back = read_spectrum(tmp_path / "back.csv")
    orig = read_spectrum(src)
    assert back.kind == kind
    assert np.max(np.abs(back.values - orig.values) / np.abs(orig.values)) < 1e-12


@pytest.mark.parametrize("line", ["# MHz MA S R 50", "# S MHZ R 50 MA", "# r 50 ma mhz s",
                                  "#MHz MA S", "# MHz S MA R 50 ! a comment"])
def test_option_line_fields_in_any_order(tmp_path: Path, line: str) -> None:
    p = tmp_path / "a.s1p"
    p.write_text(f"! head\n\n{line}\n! between\n1 0.5 90 ! tail comment\n\n2 0.5 -90\n")
    d = read_spectrum(p)
    assert d.kind == "S" and d.z0 == 50.0
    assert d.freq_hz.tolist() == [1e6, 2e6]
    assert abs(d.values[0, 0, 0] - 0.5j) < 1e-15


def test_second_option_line_ignored_and_defaults(tmp_path: Path) -> None:
    p = tmp_path / "a.s1p"
    p.write_text("#\n# Hz Z RI R 1\n1 0.5 0.5\n")    # defaults GHz S MA R 50
    d = read_spectrum(p)
    assert d.kind == "S" and d.z0 == 50.0 and d.freq_hz[0] == 1e9
    assert abs(d.values[0, 0, 0] - 0.5 * np.exp(1j * np.deg2rad(0.5))) < 1e-15


@pytest.mark.parametrize("line,problem", [
    ("# Hz S RI R 50 R 75", "given twice"), ("# Hz S RI Q", "unknown field"),
    ("# Hz S RI R -5", "bad reference resistance"), ("# Hz S RI R", "R without a value"),
    ("# kHz MHz S", "given twice")])
def test_bad_option_lines(tmp_path: Path, line: str, problem: str) -> None:
    from vfmodel.errors import InputError

    p = tmp_path / "a.s1p"
    p.write_text(f"{line}\n1 0 0\n")
    with pytest.raises(InputError, match=problem):
        read_spectrum(p)


def _s2p_rows(n: int = 10) -> list[str]:
    return [f"{k + 1} " + " ".join(f"0.{k}{j}" for j in range(8)) for k in range(n)]


def test_two_port_decreasing_frequency_is_refused(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """scikit-rf reads 6 of 10 points (it takes the decrease for a noise block)."""
    rows = _s2p_rows()
    rows[6], rows[7] = rows[7], rows[6]
    p = tmp_path / "swap.s2p"
    p.write_text("# GHz S RI R 50\n" + "\n".join(rows) + "\n")
    assert _cli("convert", str(p), str(tmp_path / "o.csv")) == 2
    err = capsys.readouterr().err
    assert str(p) in err and "line 9" in err and "decreasing frequency" in err
    assert not (tmp_path / "o.csv").exists()


def test_two_port_noise_block_is_skipped(tmp_path: Path) -> None:
    rows = _s2p_rows(4)
    noise = ["1 0.5 0.3 40 0.2", "2 0.6 0.3 45 0.2"]
    p = tmp_path / "noise.s2p"
    p.write_text("# GHz S RI R 50\n" + "\n".join([*rows, "! noise", *noise]) + "\n")
    d = read_spectrum(p)
    assert d.n_freq == 4 and d.freq_hz[-1] == 4e9


def test_touchstone_version_2(tmp_path: Path) -> None:
    p = tmp_path / "a.ts"
    p.write_text("[Version] 2.0\n# MHz RI Z R 50\n[Number of Ports] 1\n"
                 "[Number of Frequencies] 2\n[Network Data]\n1 10 1\n2 20 2\n[End]\n")
    d = read_spectrum(p)
    assert d.kind == "Z" and d.freq_hz.tolist() == [1e6, 2e6]
    assert abs(d.values[0, 0, 0] - (10 + 1j)) < 1e-9     # version 2: not normalised


def test_binary_touchstone_refused_before_reading_it_all(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    from vfmodel.errors import InputError

    p = tmp_path / "big.s1p"
    with open(p, "wb") as fh:
        fh.write(b"# Hz S RI\n\x00\x01" + b"\x00" * (4 * 2**20))
    reads: list[int] = []
    real_open = open

    class Spy:
        def __init__(self, fh: object) -> None:
            self.fh = fh

        def __enter__(self) -> Spy:
            return self

        def __exit__(self, *a: object) -> None:
            self.fh.close()  # type: ignore[attr-defined]

        def read(self, n: int = -1) -> bytes:
            data = self.fh.read(n)  # type: ignore[attr-defined]
            reads.append(len(data))
            return data

    import vfmodel.core.text as text_mod

    monkeypatch.setattr(text_mod, "open", lambda *a, **k: Spy(real_open(*a, **k)),
                        raising=False)
    with pytest.raises(InputError, match="binary"):
        read_spectrum(p)
    assert sum(reads) <= 65536
