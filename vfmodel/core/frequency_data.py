"""`FrequencyData`: a sampled frequency response, validated once."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vfmodel._choices import KINDS, Kind
from vfmodel.core import netparams
from vfmodel.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    import skrf


MAX_VALUE = 1e100
"""Largest magnitude of a response value: the fits form Gram matrices of the (weighted)
data times their basis, whose squares overflow from about 1e154 (a Touchstone file of 1e300
values ended in an internal error in ``fit`` and printed norms of inf in ``info``)."""


@dataclass(frozen=True)
class FrequencyData:
    """Frequency response samples ``values[k, i, j]`` at ``freq_hz[k]``.

    Parameters
    ----------
    freq_hz : array (n_freq,)
        Strictly increasing, non-negative, finite frequencies in Hz.
    values : array (n_freq, n_out, n_in), (n_freq, n) or (n_freq,)
        Complex response; 1-D input is a 1x1 response, 2-D input a column (n_out, 1).
    kind : {"Z", "Y", "S", "H"}
        Impedance, admittance, scattering (needs ``z0``) or general transfer.
    z0 : float, optional
        Real reference impedance of S data (default 50 ohm for S, None otherwise).
    labels : tuple of str, optional
        Port (Z/Y/S) or output names.
    source : str, optional
        Where the data came from (file name), used in messages.
    """

    freq_hz: NDArray[np.float64]
    values: NDArray[np.complex128]
    kind: Kind = "Z"
    z0: float | None = None
    labels: tuple[str, ...] = ()
    source: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        src = self.source or "FrequencyData"
        if self.kind not in KINDS:
            raise InputError(
                "unknown kind", source=src, found=repr(self.kind), expected=f"one of {KINDS}"
            )
        f = np.asarray(self.freq_hz, dtype=float).copy()
        v = np.asarray(self.values)
        if not np.iscomplexobj(v):
            v = v.astype(float)
        v = v.astype(complex).copy()
        if f.ndim != 1 or f.size == 0:
            raise InputError(
                "frequency axis must be a non-empty 1-D array",
                source=src,
                found=f"shape {f.shape}",
            )
        if v.ndim == 1:
            v = v[:, None, None]
        elif v.ndim == 2:
            v = v[:, :, None]
        if v.ndim != 3 or v.shape[0] != f.size:
            raise InputError(
                "values must have shape (n_freq, n_out, n_in)",
                source=src,
                found=f"values shape {np.shape(self.values)} for {f.size} frequencies",
            )
        if v.shape[1] == 0 or v.shape[2] == 0:
            raise InputError("values have no response entries", source=src)
        if not np.all(np.isfinite(f)):
            i = int(np.argmin(np.isfinite(f)))
            raise InputError(
                "frequency is not finite", source=src, place=f"point {i}", found=str(f[i])
            )
        if not np.all(np.isfinite(v)):
            i = int(np.argmin(np.all(np.isfinite(v), axis=(1, 2))))
            raise InputError(
                "response value is NaN or infinite",
                source=src,
                place=f"frequency point {i} ({f[i]:g} Hz)",
                expected="finite numbers",
            )
        big = np.abs(v) > MAX_VALUE
        if np.any(big):
            i = int(np.argmax(np.any(big, axis=(1, 2))))
            raise InputError(
                "response value too large: its square overflows the fits' least-squares "
                "systems and the norms of the data",
                source=src,
                place=f"frequency point {i} ({f[i]:g} Hz)",
                found=f"magnitude {float(np.max(np.abs(v[i]))):.3g}",
                expected=f"magnitudes below {MAX_VALUE:g} (rescale the data)",
            )
        if np.any(f < 0):
            i = int(np.argmax(f < 0))
            raise InputError(
                "negative frequency", source=src, place=f"point {i}", found=f"{f[i]:g} Hz"
            )
        df = np.diff(f)
        if np.any(df <= 0):
            i = int(np.argmax(df <= 0)) + 1
            what = "duplicate" if df[i - 1] == 0 else "decreasing"
            raise InputError(
                f"{what} frequency",
                source=src,
                place=f"point {i}",
                found=f"{f[i]:g} Hz after {f[i - 1]:g} Hz",
                expected="strictly increasing frequencies",
            )
        z0 = self.z0
        if self.kind == "S":
            z0 = 50.0 if z0 is None else float(z0)
            if not (np.isfinite(z0) and z0 > 0):
                raise InputError("reference impedance z0 must be positive", source=src)
        elif z0 is not None:
            z0 = float(z0)
        if self.kind in ("Z", "Y", "S") and v.shape[1] != v.shape[2]:
            raise InputError(
                f"{self.kind} data must be square",
                source=src,
                found=f"{v.shape[1]}x{v.shape[2]}",
            )
        labels = tuple(str(x) for x in self.labels)
        if labels and len(labels) != v.shape[1]:
            raise InputError(
                "number of labels does not match the outputs",
                source=src,
                found=str(len(labels)),
                expected=str(v.shape[1]),
            )
        f.setflags(write=False)
        v.setflags(write=False)
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "values", v)
        object.__setattr__(self, "z0", z0)
        object.__setattr__(self, "labels", labels)

    # ------------------------------------------------------------------ shape helpers
    @property
    def n_freq(self) -> int:
        return int(self.freq_hz.size)

    @property
    def n_out(self) -> int:
        return int(self.values.shape[1])

    @property
    def n_in(self) -> int:
        return int(self.values.shape[2])

    @property
    def omega(self) -> NDArray[np.float64]:
        """Angular frequencies, rad/s."""
        return 2 * np.pi * self.freq_hz

    def with_values(self, values: ArrayLike, **changes: Any) -> FrequencyData:
        """A copy with other values (and optionally other fields)."""
        fields: dict[str, Any] = {
            "freq_hz": self.freq_hz,
            "values": values,
            "kind": self.kind,
            "z0": self.z0,
            "labels": self.labels,
            "source": self.source,
        }
        fields.update(changes)
        return FrequencyData(**fields)

    def select(self, mask: NDArray[np.bool_]) -> FrequencyData:
        """The subset of frequency points where ``mask`` is true."""
        return self.with_values(self.values[mask], freq_hz=self.freq_hz[mask])

    # ------------------------------------------------------------------ conversions
    def to_kind(self, kind: Kind, z0: float | None = None) -> FrequencyData:
        """Convert between Z, Y and S (``z0`` for S; default: own z0 or 50 ohm)."""
        if kind == self.kind and (kind != "S" or z0 is None or z0 == self.z0):
            return self
        if "H" in (kind, self.kind):
            raise InputError(
                f"cannot convert {self.kind} data to {kind}",
                source=self.source,
                expected="network parameters Z, Y or S on both sides",
            )
        ref = float(z0 if z0 is not None else (self.z0 if self.z0 is not None else 50.0))
        own = float(self.z0 if self.z0 is not None else ref)
        values = self.values
        src: str = self.kind
        if src == "S" and kind == "S":  # renormalise via Z
            values = netparams.s2z(values, own)
            src = "Z"
        try:
            out = netparams.convert(values, src, kind, own if src == "S" else ref)
        except InputError as err:
            raise InputError(str(err), source=self.source) from None
        return self.with_values(out, kind=kind, z0=ref if kind == "S" else None)

    def to_network(self, z0: float | None = None) -> skrf.Network:
        """The data as a :class:`skrf.Network` (S-parameters at ``z0``)."""
        import skrf

        s = self.to_kind("S", z0)
        freq = skrf.Frequency.from_f(self.freq_hz, unit="Hz")
        return skrf.Network(frequency=freq, s=np.array(s.values), z0=s.z0)

    @classmethod
    def from_network(
        cls, network: skrf.Network, kind: Kind = "S", source: str | None = None
    ) -> FrequencyData:
        """Read a :class:`skrf.Network` as Z, Y or S data (S at the network's real z0)."""
        z0s = np.asarray(network.z0)
        z0 = complex(z0s.flat[0]) if z0s.size else 50.0
        if kind not in ("S", "Z", "Y"):
            raise InputError(f"a network cannot be read as {kind}", expected="Z, Y or S")
        if z0s.size and (abs(z0.imag) > 0 or not (bool(np.all(z0s == z0))
                                                  or np.allclose(z0s, z0))):
            network, z0 = _common_reference(network, z0s, kind, source or network.name)
        # only the kind asked for: skrf converts on every access of .z and .y
        values = network.s if kind == "S" else network.z if kind == "Z" else network.y
        return cls(
            freq_hz=network.f,
            values=values,
            kind=kind,
            z0=z0.real if kind == "S" else None,
            source=source or network.name,
        )


def as_frequency_data(
    data: Any, kind: Kind | None = None, *, source: str = "data"
) -> FrequencyData:
    """The one data argument of the public API as :class:`FrequencyData`.

    Accepts a :class:`FrequencyData`, a :class:`skrf.Network` (read as S at its real
    reference impedance, or as ``kind``) or a path to a Touchstone or CSV spectrum (read
    by :func:`vfmodel.read_spectrum`); with ``kind`` the data is converted to that kind.

    Raises
    ------
    InputError
        Anything else, or a conversion the data does not allow.
    """
    import os

    if isinstance(data, FrequencyData):
        fd = data
    elif isinstance(data, str | os.PathLike):
        from vfmodel.core.io_spectrum import read_spectrum

        fd = read_spectrum(data)
    else:
        try:
            import skrf
        except ImportError:  # pragma: no cover
            skrf = None
        if skrf is None or not isinstance(data, skrf.Network):
            raise InputError(
                "data must be a FrequencyData, a skrf.Network or a path to a spectrum file",
                source=source,
                found=type(data).__name__,
                expected="FrequencyData, skrf.Network, str or os.PathLike",
            )
        fd = FrequencyData.from_network(data, kind=kind if kind in ("Z", "Y") else "S")
    if kind is not None:
        if kind not in KINDS:
            raise InputError("unknown kind", source=source, found=repr(kind),
                             expected=f"one of {KINDS}")
        if kind != fd.kind:
            if kind == "H" or fd.kind == "H":
                raise InputError(
                    f"{fd.kind} data cannot be converted to {kind}",
                    source=fd.source or source,
                    expected=f"{fd.kind} (or Z/Y/S conversions between network parameters)",
                )
            fd = fd.to_kind(kind)
    return fd


def _common_reference(network: skrf.Network, z0s: NDArray[Any], kind: str, src: str
                      ) -> tuple[skrf.Network, complex]:
    """A network whose ports have different reference impedances: Z and Y do not depend
    on them; S is renormalised with scikit-rf (its wave definition, ``network.s_def``) to
    port 1's (at the lowest frequency, its real part): Touchstone 2's ``[Reference]``,
    Touchstone 1.1's ``R`` per port, and the complex, frequency-dependent ``! Port
    Impedance`` comments of an HFSS export. A :class:`~vfmodel.errors.VfmodelWarning` says
    so. References that are not finite or whose real part is not positive are refused.

    One rule for all: HFSS's ports of 6.5, 14.4 and 13.6 ohm (hfss_18.2.s3p) renormalised
    to 50 ohm instead made a strongly reflecting S whose 8-pole fit (1.2e-6, against
    1.3e-11 at port 1's 6.47 ohm) was enforced to 3.1x its bound (1.3x at 6.47 ohm)."""
    per_port = z0s.reshape(-1, z0s.shape[-1])
    if not (np.all(np.isfinite(per_port)) and np.all(per_port.real > 0)):
        raise InputError(
            "reference impedances must be finite with a positive real part",
            source=src, found=f"z0 values {np.unique(z0s)[:4]}")
    constant = bool(np.all(per_port.imag == 0) and np.allclose(per_port, per_port[:1]))
    ref = float(per_port[0, 0].real)
    if kind != "S":
        return network, complex(ref)
    import warnings

    from vfmodel.errors import VfmodelWarning

    out = network.copy()
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        out.renormalize(ref)
    if not np.all(np.isfinite(out.s)):
        raise InputError("the S-parameters cannot be renormalised to a common reference "
                         f"impedance of {ref:g} ohm (not finite)", source=src,
                         found=f"z0 values {np.unique(z0s)[:4]}")
    if constant:
        ports = ", ".join(f"{v:g}" for v in per_port[0].real)
        warnings.warn(f"{src}: the ports' reference impedances differ ({ports} ohm); the "
                      f"S-parameters are renormalised to port 1's {ref:g} ohm, the model's "
                      "z0", VfmodelWarning, stacklevel=3)
    else:
        lo, hi = float(np.min(np.abs(per_port))), float(np.max(np.abs(per_port)))
        warnings.warn(f"{src}: the ports' reference impedances are complex or vary with "
                      f"frequency (|z0| {lo:.4g}-{hi:.4g} ohm, e.g. an HFSS export's port "
                      f"impedances); the S-parameters are renormalised to port 1's {ref:.6g} "
                      "ohm (at the lowest frequency), the model's z0", VfmodelWarning,
                      stacklevel=3)
    return out, complex(ref)

