"""Port reference impedances other than one real R: Touchstone 1.1's one R per port in
the option line and an HFSS export's per-frequency ``! Port Impedance`` comments. Both were
read wrongly: the first refused ("unknown field '50'", Xyce's sparams-ts2.cir.s3p), the
second read as R 50 although its S-parameters are normalised to the port impedances
(hfss_18.2.s3p: 6.5, 14.4 and 13.6 ohm). Reference: the analytic S of a T network at
50 ohm, and scikit-rf renormalising the same file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from vfmodel import read_spectrum
from vfmodel.errors import InputError, VfmodelWarning

skrf = pytest.importorskip("skrf")

F_HZ = np.linspace(1e8, 1e9, 7)
ArrC = NDArray[np.complex128]


def _tee(f_hz: NDArray[np.float64], z0: float) -> ArrC:
    """S at reference z0 of a T network (series 10 ohm + 5 nH, shunt 2 pF, series 20 ohm)
    from its Z matrix in closed form: S = (Z - z0 I)(Z + z0 I)^-1."""
    w = 2 * np.pi * f_hz
    za, zb, zc = 10.0 + 1j * w * 5e-9, 20.0 + 0 * w, 1 / (1j * w * 2e-12)
    z = np.empty((f_hz.size, 2, 2), complex)
    z[:, 0, 0], z[:, 1, 1] = za + zc, zb + zc
    z[:, 0, 1] = z[:, 1, 0] = zc
    eye = np.eye(2)
    return np.asarray((z - z0 * eye) @ np.linalg.inv(z + z0 * eye), dtype=complex)


def _rows(s: ArrC) -> list[str]:
    return [f"{F_HZ[k]:.12e} " + " ".join(f"{x.real:+.16e} {x.imag:+.16e}" for x in
                                            (s[k, 0, 0], s[k, 1, 0], s[k, 0, 1], s[k, 1, 1]))
            for k in range(s.shape[0])]


def test_hfss_port_impedances_are_renormalised_to_port_1s(tmp_path: Path) -> None:
    # the T network's S at complex, frequency-dependent port impedances (HFSS's
    # default wave definition, as scikit-rf reads such files), written as HFSS does
    z_ports = np.stack([30.0 - 0.4j + 1e-9j * F_HZ, 5.3 - 0.005j + 0 * F_HZ], axis=1)
    net = skrf.Network(frequency=skrf.Frequency.from_f(F_HZ, unit="Hz"),
                       s=_tee(F_HZ, 50.0), z0=50.0, s_def="traveling")
    net.renormalize(z_ports)
    lines = ["! exported by a field solver", "# HZ S RI R 50"]
    for k, row in enumerate(_rows(net.s)):
        zs = " ".join(f"{z.real:.16e} {z.imag:.16e}" for z in z_ports[k])
        lines += [row, f"! Port Impedance {zs}"]  # HFSS: after the row
    path = tmp_path / "hfss.s2p"
    path.write_text("\n".join(lines) + "\n")
    with pytest.warns(VfmodelWarning, match=r"complex or vary with frequency.*renormalised "
                      r"to port 1's 30 ohm"):
        data = read_spectrum(path)
    assert data.kind == "S" and data.z0 == 30.0  # port 1's real part at the lowest frequency
    # reference 1: the closed form at 30 ohm
    assert np.max(np.abs(data.values - _tee(F_HZ, 30.0))) < 1e-12
    # reference 2: scikit-rf reading and renormalising the file
    ref = skrf.Network(str(path))
    ref.renormalize(30.0)
    assert np.max(np.abs(data.values - ref.s)) < 1e-13


def test_port_impedance_comments_equal_to_r_change_nothing(tmp_path: Path) -> None:
    # scikit-rf's own files write '! Port Impedance 50 0 ...' beside R 50, as pairs;
    # TouchstoneParser.jl's spiral inductor as a matrix ('50 0 0 0 0 0 50 0'). Both are R:
    # vfmodel's own parser reads the file (handed to scikit-rf, the spiral's MA values
    # rounded differently in the last digit and its automatic order moved from 56 to 33
    # poles), bit-identical to the file without comments
    from vfmodel.core.io_touchstone import _hfss_references_differ

    rows = _rows(_tee(F_HZ, 50.0))
    path = tmp_path / "plain.s2p"
    path.write_text("\n".join(["# HZ S RI R 50", *rows]) + "\n")
    plain = read_spectrum(path)
    for comment in ("! Port Impedance 50.0 0.0 50.0 0.0",
                    "! Port Impedance50  0  0  0  0  0  50  0"):
        lines = ["# HZ S RI R 50"] + [x for row in rows for x in (row, comment)]
        assert not _hfss_references_differ(lines, 50.0, 2, F_HZ.size, "x.s2p")
        path.write_text("\n".join(lines) + "\n")
        assert np.array_equal(read_spectrum(path).values, plain.values)
    # other references, or a block wrapped over a continuation line: scikit-rf reads them
    for block in (["! Port Impedance 30 0 0 0 0 0 50 0"], ["! Port Impedance 50 0 50 0.5"],
                  ["! Port Impedance 50 0 50", "! 0"]):
        lines = ["# HZ S RI R 50", rows[0], *block]
        assert _hfss_references_differ(lines, 50.0, 2, 1, "x.s2p")


@pytest.mark.parametrize("blocks, message", [
    (["50 nan 50 0"], "not finite or has no positive real part"),
    (["-5 0 50 0"], "not finite or has no positive real part"),
    (["50 0 50"], "an odd count of numbers"),
    (["30 -0.4 5.3 0", None], "one block per frequency.*1 blocks for 2 frequencies"),
])
def test_bad_port_impedance_comments_are_refused(tmp_path: Path, blocks: list[str | None],
                                                 message: str) -> None:
    # scikit-rf failed on these with an AttributeError or a ValueError (exit 2 "not a
    # readable Touchstone file"); now one message names the line or the counts
    lines = ["# HZ S RI R 50"]
    for row, block in zip(_rows(_tee(F_HZ[:2], 50.0)), [*blocks, None][:2], strict=True):
        lines += [row] + ([] if block is None else [f"! Port Impedance {block}"])
    path = tmp_path / "bad.s2p"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=message):
        read_spectrum(path)


def test_one_r_per_port_in_the_option_line(tmp_path: Path) -> None:
    # Touchstone 1.1: '# HZ S RI R 50 100' gives port 2 a 100-ohm reference
    s100 = skrf.Network(frequency=skrf.Frequency.from_f(F_HZ, unit="Hz"),
                        s=_tee(F_HZ, 50.0), z0=50.0)
    s100.renormalize(np.array([50.0, 100.0]))
    path = tmp_path / "perport.s2p"
    path.write_text("\n".join(["# HZ S RI R 50 100", *_rows(s100.s)]) + "\n")
    with pytest.warns(VfmodelWarning, match=r"differ \(50, 100 ohm\).*port 1's 50 ohm"):
        data = read_spectrum(path)
    assert data.z0 == 50.0
    assert np.max(np.abs(data.values - _tee(F_HZ, 50.0))) < 1e-12
    # all alike: one reference, no warning, the values as with a single R
    path.write_text("\n".join(["# HZ S RI R 75 75", *_rows(_tee(F_HZ, 75.0))]) + "\n")
    assert read_spectrum(path).z0 == 75.0
    # a count that is neither 1 nor the ports': refused, naming both
    path.write_text("\n".join(["# HZ S RI R 50 100 75", *_rows(s100.s)]) + "\n")
    with pytest.raises(InputError, match=r"one R per port.*3 values after R.*1 or 2"):
        read_spectrum(path)


def test_complex_reference_of_a_network_is_renormalised() -> None:
    # a scikit-rf Network with a complex port reference (was refused): renormalised to
    # port 1's 50 ohm, equal to the closed form there
    from vfmodel.core.frequency_data import FrequencyData

    net = skrf.Network(frequency=skrf.Frequency.from_f(F_HZ, unit="Hz"),
                       s=_tee(F_HZ, 50.0), z0=50.0)
    net.renormalize(np.array([50.0, 50.0 + 5j]))
    with pytest.warns(VfmodelWarning, match="renormalised to port 1's 50 ohm"):
        data = FrequencyData.from_network(net)
    assert np.max(np.abs(data.values - _tee(F_HZ, 50.0))) < 1e-12
    bad = net.copy()
    bad.z0 = np.array([50.0, -5.0])
    with pytest.raises(InputError, match="positive real part"):
        FrequencyData.from_network(bad)
