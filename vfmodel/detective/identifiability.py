"""Identifiability of the detective's final network and of every effect it tried (issue 14).

Parameters are varied as ``x = ln p``. Near the fit, the noise-normalised residual ``r``
(unit variance per entry under the null hypothesis) is linear in ``x`` with Jacobian
``J``, so the Fisher information of the data is ``F_d = J^T J`` and the Cramer-Rao bound
on the covariance of ``x`` is ``F_d^+`` (a direction the data do not see at all: infinite
variance, :func:`vfmodel.greybox.lsq.log_covariance`). A physical prior
(:func:`vfmodel.greybox.priors.parameter_priors`) adds the information ``1 / s_i^2`` of
a normal law of ``x_i`` with ``s_i`` the prior's standard deviation of ``ln p``
(log-normal: ``ln gsd``; log-uniform range: ``ln(upper / lower) / sqrt(12)``, the
variance-matched normal), so the posterior covariance is ``(F_d + diag(1/s^2))^-1``
(Laplace approximation around the fitted values; the detective's fits themselves do not
use the prior, so this is the information the prior would add at the same point).

Classification of a parameter, from the marginal standard deviation ``std`` of ``ln p``
(correlations with every other fitted parameter included):

- ``identifiable``: the data alone give ``std < IDENTIFIED_STD_LOG``;
- ``prior-only``: only data and prior together do;
- ``not-identifiable``: not even data and prior together.

``IDENTIFIED_STD_LOG = 1.0``: the 95 % interval ``p exp(+-1.96 std)`` then spans less
than a factor ``exp(3.92) ~ 50``, i.e. the value is known to within about an order of
magnitude either way. That is the resolution at which a grey-box parameter says
something physical (the priors themselves have geometric standard deviations 1.5-10), the
same bound the detective uses to call a finding's parameters determined
(:func:`vfmodel.detective.diagnose.diagnose`) and the reports use for "not determined by
the data". A prior with ``s < 1`` (``gsd < e``: the air-gap and winding-rotor
capacitances, the shaft inductances) makes its parameter at least ``prior-only`` on its
own: those values are known from geometry.

Classification of an effect (a candidate tried, or a finding), from the refit that added it
(its trial; ``k`` new parameters, ``Delta chi2`` = with minus without):

- ``not-identifiable`` when another effect explains the data about as well (an ambiguous
  finding), or when its new parameters are not determined even with their prior
  (largest ``std`` >= the bound). When in addition ``|Delta chi2| < k`` the data do not
  distinguish the network with the effect from the one without: the classical sign of a
  change the data cannot see (a change of ``chi2`` smaller than its number of parameters
  is what fitting noise alone gives);
- ``prior-only`` when its new parameters are determined only with their prior;
- ``identifiable`` when the data alone determine them (and no alternative is as good).

A trial whose ``Delta chi2`` is positive beyond ``k`` (the network with the effect contains
the one without, so its optimum cannot be worse) stopped short of its optimum: the
effect is then ``not-identifiable`` with that reason, as the local curvature of such a
point says nothing about the effect.

An effect without parameters of its own (``metallic_contact``, a switch of the bearing
state) is ``identifiable`` when ``|Delta chi2| >= SWITCH_SEEN_CHI2`` (10: very strong
evidence on the scale the detective accepts effects with, Kass and Raftery 1995) and no
alternative is as good, else ``not-identifiable``. (The bound was 1, as for one fitted
parameter; but a switch is no fitted parameter: on a concealed metallic contact, case
``pmsm_contact`` of ``make_concealed.py``, the maximum a posteriori fit without the
contact reached the network with it within Delta chi2 1.2 at a plausible standstill film,
and the contact was called identifiable while the data do not tell the two apart.)

A ``std`` that is infinite (a direction of no sensitivity at all) is written as ``null``
in ``diagnosis.json``.

References
----------
H. Cramer, "Mathematical Methods of Statistics", Princeton, 1946 (the information bound).
A. Raue et al., "Structural and practical identifiability analysis of partially observed
dynamical models by exploiting the profile likelihood", Bioinformatics 25(15), 1923-1929,
2009. doi:10.1093/bioinformatics/btp358 (practical non-identifiability: a parameter whose
confidence interval is unbounded although the model is structurally identifiable).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from vfmodel.detective.fit import FitResult
from vfmodel.detective.problem import Candidate, Family
from vfmodel.greybox.lsq import log_covariance
from vfmodel.greybox.params import ParamSet

__all__ = [
    "IDENTIFIED_STD_LOG",
    "SWITCH_SEEN_CHI2",
    "Assessment",
    "EffectIdentifiability",
    "Identifiability",
    "assess",
    "classify",
    "effect_identifiability",
    "fisher_cov",
    "fisher_std",
    "grey_box_prior_sigma",
    "grey_box_priors",
    "identifiability",
    "jacobian",
    "last_trial",
]

ArrF = NDArray[np.float64]
Status = Literal["identifiable", "prior-only", "not-identifiable"]

IDENTIFIED_STD_LOG = 1.0
"""Standard deviation of ``ln p`` below which a parameter is determined (module docstring)."""
SWITCH_SEEN_CHI2 = 10.0
"""``|Delta chi2|`` from which the data see a switch without parameters (module docstring)."""

_FD_STEP = 1e-6


def fisher_std(jac: ArrF, prior_sigma: Sequence[float | None] | None = None) -> ArrF:
    """Marginal standard deviation of each ``x_i = ln p_i`` from ``J^T J`` of the whitened
    residual, plus ``1 / s_i^2`` on the diagonal for every finite ``prior_sigma[i]``
    (``None``: no prior). Unseen directions give ``inf``."""
    return np.sqrt(np.maximum(np.diag(fisher_cov(jac, prior_sigma)), 0.0))


def fisher_cov(jac: ArrF, prior_sigma: Sequence[float | None] | None = None) -> ArrF:
    """Covariance of ``x = ln p`` of :func:`fisher_std` (``inf`` on the diagonal of an
    unseen direction)."""
    j = np.asarray(jac, dtype=float)
    k = j.shape[1]
    if k == 0:
        return np.zeros((0, 0))
    rows = []
    if prior_sigma is not None:
        for i, s in enumerate(prior_sigma):
            if s is not None and math.isfinite(s) and s > 0:
                e = np.zeros(k)
                e[i] = 1.0 / s
                rows.append(e)
    a = np.vstack([j, *rows]) if rows else j
    return log_covariance(a, rcond=1e-12)


def classify(std_data: float, std_post: float,
             threshold: float = IDENTIFIED_STD_LOG) -> Status:
    """The class of one parameter (module docstring)."""
    if std_data < threshold:
        return "identifiable"
    if std_post < threshold:
        return "prior-only"
    return "not-identifiable"


def jacobian(family: Family, applied: Sequence[Candidate], params: ParamSet,
             names: Sequence[str]) -> ArrF:
    """``d r / d ln p`` of the family's residual at ``params``: the family's own
    (``residual_jacobian``, e.g. adjoint) when it has one, else forward differences."""
    from vfmodel.detective.fit import evaluate

    own = getattr(family, "residual_jacobian", None)
    if own is not None:
        return np.asarray(own(tuple(applied), params, tuple(names))[1], dtype=float)
    r0 = evaluate(family, applied, params)
    cols = []
    for n in names:
        v = params[n]
        spec = next(s for s in params.specs if s.name == n)
        h = _FD_STEP if v * math.exp(_FD_STEP) <= spec.upper else -_FD_STEP
        p1 = params.with_values({n: v * math.exp(h)})
        cols.append((evaluate(family, applied, p1) - r0) / h)
    return np.stack(cols, axis=1) if cols else np.zeros((r0.size, 0))


@dataclass(frozen=True)
class Identifiability:
    """Per parameter: standard deviation of ``ln p`` from the data alone and from data and
    prior (``inf``: unseen), the prior's own (``None``: no prior), and the class."""

    names: tuple[str, ...]
    std_data: ArrF
    std_post: ArrF
    prior_sigma: tuple[float | None, ...]
    status: tuple[Status, ...]
    cov_post: ArrF | None = None

    def as_dict(self) -> dict[str, Status]:
        return dict(zip(self.names, self.status, strict=True))


def identifiability(jac: ArrF, names: Sequence[str],
                    prior_sigma: Mapping[str, float] | None = None,
                    threshold: float = IDENTIFIED_STD_LOG) -> Identifiability:
    """Classify the parameters ``names`` (columns of ``jac``) (module docstring)."""
    ps: tuple[float | None, ...] = tuple((prior_sigma or {}).get(n) for n in names)
    sd = fisher_std(jac)
    cp = fisher_cov(jac, ps)
    sp = np.sqrt(np.maximum(np.diag(cp), 0.0))
    st = tuple(classify(float(a), float(b), threshold) for a, b in zip(sd, sp, strict=True))
    return Identifiability(tuple(names), sd, sp, ps, st, cp)


@dataclass(frozen=True)
class EffectIdentifiability:
    """One effect: its class, the largest ``std`` of its new parameters from the data and
    from data and prior, the trial's ``Delta chi2`` and ``k``, and why."""

    effect: str
    location: str
    status: Status
    std_data: float
    std_post: float
    delta_chi2: float
    n_params: int
    reason: str
    undetermined: tuple[str, ...] = ()

    def as_json(self) -> dict[str, Any]:
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {"location": self.location, "status": self.status,
                "max_std_log_data": f(self.std_data), "max_std_log_with_prior": f(self.std_post),
                "delta_chi2": f(self.delta_chi2), "n_params": self.n_params,
                "reason": self.reason}


def effect_identifiability(cand: Candidate, fit: FitResult, jac: ArrF, delta_chi2: float,
                           prior_sigma: Mapping[str, float] | None = None,
                           alternatives: Sequence[str] = (),
                           threshold: float = IDENTIFIED_STD_LOG) -> EffectIdentifiability:
    """Class of the effect ``cand`` from its trial ``fit`` (whose columns of ``jac`` are
    ``fit.names``) and ``delta_chi2`` (with minus without); ``alternatives`` are effects
    that explain the data about as well (module docstring)."""
    new = [n for n in (s.name for s in cand.params) if n in fit.names]
    k = len(new)
    ident = identifiability(jac, fit.names, prior_sigma, threshold)
    idx = [fit.names.index(n) for n in new]
    sd = float(np.max(ident.std_data[idx])) if idx else 0.0
    sp = float(np.max(ident.std_post[idx])) if idx else 0.0
    seen = abs(delta_chi2) >= (max(k, 1) if k else SWITCH_SEEN_CHI2)
    dc = (f"Delta chi2 {delta_chi2:+.3g} for {k} parameter{'s' * (k != 1)}"
          + ("" if seen else (", within what fitting noise gives" if k else
                              f", below {SWITCH_SEEN_CHI2:g}") + ": the data do not tell "
             "the network with it from the one without"))
    und = tuple(n for n, i in zip(new, idx, strict=True)
                if not ident.std_data[i] < threshold)
    sds = "unbounded" if not math.isfinite(sd) else f"{sd:.3g}"
    sps = "unbounded" if not math.isfinite(sp) else f"{sp:.3g}"
    if alternatives:
        return EffectIdentifiability(
            cand.effect, cand.location, "not-identifiable", sd, sp, delta_chi2, k,
            "explained about as well by " + ", ".join(alternatives) + f" ({dc})", und)
    if delta_chi2 > max(k, 1):   # nested networks: the refit stopped short of its optimum
        return EffectIdentifiability(
            cand.effect, cand.location, "not-identifiable", sd, sp, delta_chi2, k,
            f"its refit ended worse than the network without it ({dc}): the curvature of "
            "a point short of the optimum says nothing about the effect", und)
    if k == 0 and not seen:   # a switch without parameters that the data do not see
        return EffectIdentifiability(cand.effect, cand.location, "not-identifiable", sd, sp,
                                     delta_chi2, k, f"the data do not see it ({dc})", und)
    status = classify(sd, sp, threshold)
    if k == 0:
        why = f"a switch without parameters of its own that the data see ({dc})"
    elif status == "identifiable":
        why = f"the data determine its parameters (largest std of ln p {sds}; {dc})"
    elif status == "prior-only":
        why = (f"its parameters are determined only with their physical prior (std of ln p "
               f"{sds} from the data, {sps} with the prior; {dc})")
    elif not any((prior_sigma or {}).get(n) for n in new):
        why = f"its parameters are not determined (std of ln p {sds}, no prior; {dc})"
    else:
        why = (f"its parameters are not determined even with their prior (std of ln p "
               f"{sds} from the data, {sps} with the prior; {dc})")
    return EffectIdentifiability(cand.effect, cand.location, status, sd, sp, delta_chi2, k,
                                 why, und)


def grey_box_prior_sigma(names: Sequence[str], dataset: Any = None) -> dict[str, float]:
    """Prior standard deviation of ``ln p`` (:attr:`vfmodel.greybox.priors.Prior.sigma`)
    of every name in ``names`` that has a prior (:func:`grey_box_priors`)."""
    return {n: float(p.sigma) for n, p in grey_box_priors(names, dataset).items()}


def grey_box_priors(names: Sequence[str], dataset: Any = None) -> dict[str, Any]:
    """Physical prior (:class:`vfmodel.greybox.priors.Prior`) of every grey-box name in
    ``names``; a per-speed copy ``<name>@<s>rpm`` of the PMSM
    family takes the prior at ``s`` rpm, a name without a tag that of standstill for the
    speed-dependent (lubricant and contact) parameters. ``dataset``: a
    :class:`vfmodel.core.dataset.Dataset` whose ``[machine]``/``[bearing]``/``[priors]``
    tables apply (default: none, 3-300 kW)."""
    from vfmodel.greybox.priors import parameter_priors

    cache: dict[float, dict[str, Any]] = {}
    out: dict[str, Any] = {}
    for n in names:
        base, _, tag = n.partition("@")
        try:
            rpm = float(tag[:-3]) if tag.endswith("rpm") else 0.0
        except ValueError:
            continue
        if rpm not in cache:
            cache[rpm] = parameter_priors(dataset, rpm)
        if base in cache[rpm]:
            out[n] = cache[rpm][base]
    return out


_RANK = {"identifiable": 0, "prior-only": 1, "not-identifiable": 2}


@dataclass(frozen=True)
class Assessment:
    """Identifiability of a diagnosis: the final network's parameters and every effect
    tried (by ``(effect, location)``; its trial's fitted network in ``trials``)."""

    parameters: Identifiability
    effects: dict[tuple[str, str], EffectIdentifiability]

    def as_json(self, threshold: float = IDENTIFIED_STD_LOG) -> dict[str, Any]:
        """``diagnosis.json`` ``identifiability`` (CONTRACT section 7 plus details; an
        effect at several places takes its best class)."""
        def f(x: float | None) -> float | None:
            return float(x) if x is not None and math.isfinite(x) else None

        eff: dict[str, Status] = {}
        for (e, _), v in self.effects.items():
            if e not in eff or _RANK[v.status] < _RANK[eff[e]]:
                eff[e] = v.status
        p = self.parameters
        return {
            "parameters": p.as_dict(),
            "effects": eff,
            "parameter_std_log": {n: {"data": f(a), "with_prior": f(b), "prior": f(s)}
                                  for n, a, b, s in zip(p.names, p.std_data, p.std_post,
                                                        p.prior_sigma, strict=True)},
            "effect_details": {f"{e} at {loc}": v.as_json()
                               for (e, loc), v in self.effects.items()},
            "threshold_std_log": threshold,
            "definition": (
                "from the Fisher information J^T J of the noise-normalised residual at the "
                "fitted values (ln p): identifiable if the data alone give a standard "
                f"deviation of ln p below {threshold:g} (95 % interval within a factor ~50), "
                "prior-only if data and the physical prior (normal in ln p) together do, "
                "else not-identifiable; an effect by the largest std of the parameters its "
                "trial added, not-identifiable when another effect explains the data about "
                "as well; null std: a direction the data do not see at all (unbounded)"),
        }


def assess(family: Family, diag: Any, prior_sigma: Mapping[str, float] | None = None,
           threshold: float = IDENTIFIED_STD_LOG) -> Assessment:
    """Identifiability of ``diag`` (a :class:`vfmodel.detective.diagnose.Diagnosis`): the
    final network's parameters from one Jacobian at its fit, each finding from its trial
    and each rejected candidate from its last trial (one Jacobian each)."""
    fin = diag.final
    params = identifiability(jacobian(family, fin.applied, fin.params, fin.names), fin.names,
                             prior_sigma, threshold)
    effects: dict[tuple[str, str], EffectIdentifiability] = {}

    def one(t: Any, alts: Sequence[str]) -> EffectIdentifiability:
        j = jacobian(family, t.fit.applied, t.fit.params, t.fit.names)
        return effect_identifiability(t.candidate, t.fit, j, t.delta_chi2, prior_sigma, alts,
                                      threshold)

    for fnd in diag.findings:
        effects[fnd.candidate.key] = one(fnd.trial, fnd.alternatives)
    for c, _ in diag.rejected:
        t = last_trial(diag, c.key)
        if t is not None:
            effects[c.key] = one(t, ())
    return Assessment(params, effects)


def last_trial(diag: Any, key: tuple[str, str]) -> Any:
    """The candidate's trial of the last round that tried it (``None``: never tried)."""
    for rnd in reversed(diag.trials):
        for t in rnd:
            if t.candidate.key == key:
                return t
    return None
