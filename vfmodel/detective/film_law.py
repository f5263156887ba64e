"""Film law across speeds (``vfmodel diagnose --film-law``): the lubricant film of the
PMSM detective follows a parametric law in speed instead of free values per speed.

Free per-speed values (``<name>@<s>rpm``, :mod:`vfmodel.detective.pmsm`) absorb every
bearing-side effect the network lacks (a second film layer, a lubricant loss, an edge
capacitance): at each speed the film takes whatever values fit. Tied by a law, they cannot,
so what they absorbed becomes a testable misfit.

The law (in ``x = ln value``, the fit's variables, with ``n_ref`` the geometric mean of the
rotating speeds recorded)::

    ln C_1(n) = ln C_1,ref - e_C ln(n / n_ref)        (film capacitance ~ 1/h)
    ln R_1(n) = ln R_1,ref + e_R ln(n / n_ref)        (film resistance  ~ h)
    ln k_d(n) = ln k_d,  ln tau_d(n) = ln tau_d        (lubricant loss: one value)

so the per-speed values are a linear map of the law parameters, ``x_speed = A x_law``, and
the Jacobian with respect to the law parameters is ``J_speed @ A``
(:meth:`FilmLaw.expand`). The exponent ``e`` is stored as the parameter value ``exp(e)``
(``<name>~exp``), so that its fitted variable ``ln value`` is ``e`` itself and the map
stays linear; its standard deviation is the fit's ``rel_std`` of that name.

Which parameters follow a law, and why:

- ``lubricant.C_1``, ``lubricant.R_1`` (base-oil film): elasto-hydrodynamic central film
  thickness ``h ~ (eta_0 u)^0.67`` (Hamrock-Dowson,
  :func:`vfmodel.greybox.contact.central_film_thickness`), ``C_1 ~ A / h``,
  ``R_1 ~ rho h / A``. Separate exponents: the lumped ``C_1`` also holds film outside the
  Hertzian ellipse, nearly independent of ``h``, and ``R_1`` the asperity contacts that
  fade as the film grows, so the two do not scale with one power of ``h``. Bounds:
  ``e_C`` in [0, 1] (0: capacitance outside the contact dominates; the physics priors
  :func:`vfmodel.greybox.priors.parameter_priors` give ``C_1`` 7.99e-11 F at 100 rpm and
  3.83e-11 F at 300 rpm, e_C = 0.67), ``e_R`` in [0, 3] (the priors give 0.33 between 100
  and 300 rpm and 2.7 between 300 and 500 rpm, where the asperity contacts open).
- ``lubricant.k_d``, ``lubricant.tau_d`` (dielectric relaxation of the oil): a material
  property, set by temperature, not by speed: one value for every speed (exponent 0),
  the base value (it also acts at standstill when the film is not shorted there).
- ``lubricant.R_2``, ``lubricant.C_2`` (thickener layer), ``bearing.R_h`` (Hertzian
  contact resistance), ``bearing.C_edge`` (edge capacitance): stay free per speed. A
  thickener layer's thickness is not set by the EHL inlet (no established law); the
  contact resistance is set by the asperity contacts and the edge capacitance by the
  meniscus, each with its own dependence.

Temperature: a dataset has one ``temperature_c`` (``[dataset] temperature_c``; no dataset
format holds a temperature per recording), so all recordings share one viscosity and the
law is one in speed only.

The bench truth (``benches.truth.lubricant_at_speed``, used by ``scripts/make_testbench.py``
and the concealed cases) is a power law from 100 rpm: ``R_1 ~ n^1.0``, ``C_1 ~ n^-0.15``,
``R_2 ~ n^0.5``, ``C_2``, ``k_d``, ``tau_d`` constant: inside these bounds, so the law is
exact for the truth's film; its ``R_2`` exponent is free per speed here.

One rotating speed leaves no exponent to fit: :class:`FilmLaw` refuses fewer than two
rotating speeds (:class:`vfmodel.errors.InputError`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel.detective.shaft_frame import speed_tag
from vfmodel.errors import InputError
from vfmodel.greybox.params import ParamSet, ParamSpec

__all__ = ["CONSTANT", "POWER", "FilmLaw", "compare_free", "film_law_json", "speed_tag",
           "unrecorded_speed"]

ArrF = NDArray[np.float64]

POWER: dict[str, tuple[float, float, float]] = {
    "lubricant.C_1": (-1.0, 0.0, 1.0),
    "lubricant.R_1": (+1.0, 0.0, 3.0),
}
"""Power-law parameters: (sign of the exponent in ``ln value``, exponent bounds)."""

CONSTANT = ("lubricant.k_d", "lubricant.tau_d")
"""Parameters with one value at every speed (the base name)."""


def ref_name(name: str) -> str:
    return f"{name}~ref"


def exp_name(name: str) -> str:
    return f"{name}~exp"


@dataclass(frozen=True)
class FilmLaw:
    """The law for the rotating ``speeds`` (rpm), see the module docstring."""

    speeds: tuple[float, ...]

    def __post_init__(self) -> None:
        rot = tuple(sorted({float(s) for s in self.speeds if s > 0}))
        if len(rot) < 2:
            raise InputError("--film-law needs recordings at two or more rotating speeds "
                             "(a power law in speed has no exponent to fit otherwise)",
                             found=f"{len(rot)} rotating speed(s)"
                             + (f": {', '.join(f'{s:g}' for s in rot)} rpm" if rot else ""),
                             expected="recordings at >= 2 speeds > 0 rpm")
        object.__setattr__(self, "speeds", rot)

    @property
    def n_ref(self) -> float:
        """Reference speed: the geometric mean of the rotating speeds (rpm)."""
        return float(np.exp(np.mean(np.log(self.speeds))))

    def governed(self, name: str) -> bool:
        """Whether the per-speed copies of ``name`` follow the law."""
        return name in POWER or name in CONSTANT

    def law_names(self, lub: Iterable[str]) -> list[str]:
        """Law parameters replacing the per-speed copies of the governed names of ``lub``
        (the constants' base names included)."""
        out: list[str] = []
        for n in lub:
            if n in POWER:
                out += [ref_name(n), exp_name(n)]
            elif n in CONSTANT:
                out.append(n)
        return out

    def specs(self, params: ParamSet) -> list[ParamSpec]:
        """Specifications of the law parameters of ``params``: a reference value with the
        base's bounds, an exponent stored as ``exp(e)``."""
        out = []
        for n, (sign, lo, hi) in POWER.items():
            if n not in params:
                continue
            s = params.spec(n)
            out.append(ParamSpec(ref_name(n), s.nominal, s.lower, s.upper, "film law",
                                 s.unit, f"{s.description} at {self.n_ref:.4g} rpm"))
            what = "falls" if sign < 0 else "rises"
            out.append(ParamSpec(exp_name(n), math.exp(0.5 * (lo + hi)), math.exp(lo),
                                 math.exp(hi), "film law", "",
                                 f"exp(e): {n} {what} as speed^e"))
        return out

    def row(self, name: str, rpm: float) -> dict[str, float]:
        """Coefficients of ``ln <name>@<rpm>rpm`` in the law variables (one row of A)."""
        if name in POWER:
            return {ref_name(name): 1.0,
                    exp_name(name): POWER[name][0] * math.log(rpm / self.n_ref)}
        if name in CONSTANT:
            return {name: 1.0}
        raise KeyError(name)

    def values_at(self, params: ParamSet | Mapping[str, float], rpm: float
                  ) -> dict[str, float]:
        """Values of the governed parameters at ``rpm`` from the law parameters in
        ``params`` (those absent are left out)."""
        out = {}
        for n in (*POWER, *CONSTANT):
            row = self.row(n, rpm)
            if all(k in params for k in row):
                out[n] = math.exp(sum(c * math.log(params[k]) for k, c in row.items()))
        return out

    def realise(self, params: ParamSet) -> ParamSet:
        """``params`` with every governed per-speed copy set from the law (clipped to its
        bounds; the law parameters share the base bounds, so only exponents that carry a
        value beyond them at the extreme speeds clip)."""
        vals = {}
        for s in self.speeds:
            for n, v in self.values_at(params, s).items():
                if n + speed_tag(s) in params:
                    vals[n + speed_tag(s)] = v
        return params.with_values(vals, clip=True)

    def expand(self, names: Sequence[str], params: ParamSet) -> tuple[tuple[str, ...], ArrF]:
        """Network names and the map ``A``: ``x_expanded = A x_names``.

        Law names are replaced by the per-speed copies they govern (those present in
        ``params``); a constant's base name stays (it acts at standstill) and gains its
        copies. ``A`` has one row per expanded name and one column per name of ``names``,
        so that the Jacobian with respect to ``names`` is ``J_expanded @ A``."""
        col = {n: j for j, n in enumerate(names)}
        rows: list[tuple[str, dict[int, float]]] = []
        for n in names:
            if "~" not in n:
                rows.append((n, {col[n]: 1.0}))
        for n in (*POWER, *CONSTANT):
            for s in self.speeds:
                copy = n + speed_tag(s)
                coef = self.row(n, s)
                if copy in params and all(k in col for k in coef):
                    rows.append((copy, {col[k]: c for k, c in coef.items()}))
        a = np.zeros((len(rows), len(names)))
        for i, (_, cols) in enumerate(rows):
            for j, c in cols.items():
                a[i, j] = c
        return tuple(n for n, _ in rows), a

    def start(self, params: ParamSet) -> ParamSet:
        """Law parameters fitted to the per-speed values of ``params`` (least squares in
        ``ln value``; an exponent outside its bounds is clipped and the reference refitted
        with it; a constant: the mean of its per-speed ``ln`` values), then every governed
        copy realised from them."""
        vals: dict[str, float] = {}
        t = np.log(np.asarray(self.speeds) / self.n_ref)
        for n, (sign, lo, hi) in POWER.items():
            if ref_name(n) not in params:
                continue
            y = np.log([params[n + speed_tag(s)] for s in self.speeds])
            slope = float(np.polyfit(t, y, 1)[0])
            e = float(np.clip(sign * slope, lo, hi))
            vals[ref_name(n)] = float(np.exp(np.mean(y - sign * e * t)))
            vals[exp_name(n)] = math.exp(e)
        for n in CONSTANT:
            copies = [n + speed_tag(s) for s in self.speeds]
            if n in params and all(c in params for c in copies):
                vals[n] = float(np.exp(np.mean(np.log([params[c] for c in copies]))))
        return self.realise(params.with_values(vals, clip=True))


def unrecorded_speed(law: FilmLaw, params: ParamSet | Mapping[str, float],
                     names: Iterable[str], rpm: float) -> dict[str, float]:
    """Values at ``rpm``, a rotating speed that was not recorded, of the speed-dependent
    ``names``: those the law governs from the law; the others (free per speed: the
    thickener layer, contact resistance, edge capacitance) from a power law through their
    per-speed copies at the recorded speeds (least squares in ``ln value`` against
    ``ln speed``, the law's own form; this is what the network predicts for a speed that
    was not recorded, not a fitted law). Names without copies at every recorded speed
    are left out."""
    out = law.values_at(params, rpm)
    t = np.log(np.asarray(law.speeds))
    for n in names:
        copies = [n + speed_tag(s) for s in law.speeds]
        if n in out or not all(c in params for c in copies):  # (constants: in out)
            continue
        y = np.log([params[c] for c in copies])
        slope, icpt = np.polyfit(t, y, 1)
        out[n] = float(np.exp(icpt + slope * math.log(rpm)))
    return out


def film_law_json(law: FilmLaw, fit: Any) -> dict[str, Any]:
    """The fitted law of ``fit`` (a :class:`vfmodel.detective.fit.FitResult` of the law
    family): reference values with relative std, exponents with std; an exponent is
    ``determined`` when its std is below half its bound range (the data narrow it below
    the physics range; on data/pmsm40kw R_1's exponent had std 7.9: R_1 ~ 34 kOhm with
    C_1 ~ 35 nF corners at ~130 Hz, below the H1 band, so the records do not see it)."""
    out: dict[str, Any] = {"n_ref_rpm": law.n_ref, "speeds_rpm": list(law.speeds),
                           "power": {}, "constant": {}}
    for n in POWER:
        if ref_name(n) in fit.params:
            out["power"][n] = {
                "ref_value": float(fit.params[ref_name(n)]),
                "ref_rel_std": _f(fit.rel_std.get(ref_name(n), float("nan"))),
                "exponent": float(math.log(fit.params[exp_name(n)])) * POWER[n][0],
                "exponent_std": _f(std := fit.rel_std.get(exp_name(n), float("nan"))),
                "determined": bool(std < 0.5 * (POWER[n][2] - POWER[n][1])),
                "fitted": ref_name(n) in fit.names}
    for n in CONSTANT:
        if n in fit.params and n + speed_tag(law.speeds[0]) in fit.params:
            out["constant"][n] = {"value": float(fit.params[n]),
                                  "rel_std": _f(fit.rel_std.get(n, float("nan"))),
                                  "fitted": n in fit.names}
    return out


def _f(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def compare_free(law_family: Any, fit: Any, *, max_nfev: int = 30) -> dict[str, Any]:
    """Law against free per-speed values on the same data: the network of ``fit`` (fitted
    with the law) refitted with free per-speed film values, warm-started at the law's
    values; both scored by ``BIC = chi2 + k ln m`` (:class:`FitResult`). The description of
    lower BIC is the one the data support; a difference above 10 is very strong evidence
    (Kass and Raftery 1995), below it the law is kept as the simpler one only when its BIC
    is not higher."""
    from vfmodel.detective.fit import refit

    free_family = law_family.free_description()
    free = refit(free_family, fit.applied, law_family.law.realise(fit.params),
                 max_nfev=max_nfev)
    d_bic = float(fit.bic - free.bic)
    return {
        "law": {"chi2": float(fit.chi2), "k": fit.k, "bic": float(fit.bic),
                "chi2_red": float(fit.chi2_red)},
        "free": {"chi2": float(free.chi2), "k": free.k, "bic": float(free.bic),
                 "chi2_red": float(free.chi2_red)},
        "n_residuals": int(fit.n_points),
        "delta_bic_law_minus_free": d_bic,
        "supported": "law" if d_bic <= 0 else "free",
        "strength": "very strong" if abs(d_bic) > 10 else "weak",
    }
