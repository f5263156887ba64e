"""Pure array kernels converting between Z, Y and S network parameters.

All arrays are ``(n_freq, n, n)`` complex; ``z0`` is a real reference impedance common to
all ports (power-wave and pseudo-wave definitions coincide for real z0).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vfmodel.errors import InputError

Array = NDArray[np.complex128]


def _eye(a: Array) -> Array:
    return np.broadcast_to(np.eye(a.shape[-1], dtype=complex), a.shape)


def _inv(a: Array, what: str) -> Array:
    try:
        cond = np.linalg.cond(a)
    except np.linalg.LinAlgError:  # pragma: no cover - cond of empty
        cond = np.array([np.inf])
    if not np.all(np.isfinite(cond)) or np.any(cond > 1e14):
        bad = int(np.argmax(~np.isfinite(cond) | (cond > 1e14)))
        raise InputError(
            f"cannot convert: {what} is singular at frequency index {bad}",
            expected="a non-singular matrix at every frequency",
        )
    out: Array = np.linalg.inv(a).astype(complex)
    return out


def z2y(z: Array) -> Array:
    """Admittance from impedance, Y = Z^-1."""
    return _inv(z, "Z")


def y2z(y: Array) -> Array:
    """Impedance from admittance, Z = Y^-1."""
    return _inv(y, "Y")


def z2s(z: Array, z0: float) -> Array:
    """S = (Z - z0 I)(Z + z0 I)^-1."""
    eye = _eye(z)
    return (z - z0 * eye) @ _inv(z + z0 * eye, "Z + z0 I")


def s2z(s: Array, z0: float) -> Array:
    """Z = z0 (I + S)(I - S)^-1."""
    eye = _eye(s)
    return z0 * (eye + s) @ _inv(eye - s, "I - S")


def y2s(y: Array, z0: float) -> Array:
    """S = (I - z0 Y)(I + z0 Y)^-1."""
    eye = _eye(y)
    return (eye - z0 * y) @ _inv(eye + z0 * y, "I + z0 Y")


def s2y(s: Array, z0: float) -> Array:
    """Y = (I - S)(I + S)^-1 / z0."""
    eye = _eye(s)
    return (eye - s) @ _inv(eye + s, "I + S") / z0


def convert(values: Array, src: str, dst: str, z0: float) -> Array:
    """Convert network parameters ``src`` -> ``dst`` (each of "Z", "Y", "S")."""
    if src == dst:
        return values.copy()
    table = {
        ("Z", "Y"): lambda v: z2y(v),
        ("Y", "Z"): lambda v: y2z(v),
        ("Z", "S"): lambda v: z2s(v, z0),
        ("S", "Z"): lambda v: s2z(v, z0),
        ("Y", "S"): lambda v: y2s(v, z0),
        ("S", "Y"): lambda v: s2y(v, z0),
    }
    if (src, dst) not in table:
        raise InputError(
            f"cannot convert {src} parameters to {dst}", expected="Z, Y or S on both sides"
        )
    out: Array = table[(src, dst)](values)
    return out
