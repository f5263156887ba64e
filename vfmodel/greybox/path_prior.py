"""Machine covariance with the rotor current's path known only through its physics prior.

With the metallic contact closed (standstill) the shaft is tied to the frame through the
balls, and the standstill bearing voltage is the rotor current (through the winding-rotor
capacitance ``C_wr``) times the impedance of its path (shaft and ball inductances): the
standstill data fix the product ``C_wr Z_path``, not the scale (:data:`.assembly.PATH_L_MAX`,
issue 14). A model that is structurally unlike the machine (two rotor halves, two bearings,
a shaft ladder) then moves the path inductance to wherever its misfit is smallest, and
``C_wr`` follows: on independent benches 106, 109, 117 (issue 19) the standstill stage put
``shaft.L_1`` at 0.84-1 uH (physics: ~70 nH; the benches' truth ~20 nH) and ``C_wr`` at
0.07-0.28 times the truth, with a Gauss-Newton interval of a factor 1.4-3.9 that missed it:
the data's "information" about the path inductances is the model error's.

This module states that plainly. The path inductances (:data:`PATH`) are taken as
**identified only through their physics priors** (:func:`.priors.parameter_priors`); what
the data say about them is discarded, and every other parameter is conditioned on them and
then carries their prior uncertainty. With the stage's covariance ``C`` (of ``log p``) and
its information ``F = C^+`` split into the path ``P`` and the others ``o``:

    C_o|P = F_oo^+,   S = d theta_o / d theta_P = -F_oo^+ F_oP,
    M = diag(sigma^2) + d d^T,   d = mu - theta_P,
    Cov = [[C_o|P + S M S^T, S M], [M S^T, M]],

``mu_k``, ``sigma_k`` the mean and standard deviation of ``ln p_k`` under its (independent)
prior: ``M`` is the second moment of the prior's values about the fitted ones, so the
interval, centred on the fit, reaches the physical values when the fit has left them. This
is the covariance about the fit of ``theta_o`` re-estimated from the data with ``theta_P``
drawn from its prior (linear-Gaussian: the conditional estimate moves by ``S (theta_P -
theta_P_fit)``; the two-step form of :mod:`.propagate`, Murphy & Topel 1985).

Parameters that no stage fitted (:data:`.identify.STANDSTILL_HIDDEN`: the air-gap and
bearing air capacitances, held at their scaled start because the closed contact hides
them) are appended with the same prior second moment and no covariance with the others:
the machine stages were conditional on them, and :func:`.propagate.with_machine_uncertainty`
carries their effect on each lubricant through the record's own derivatives.

Consequence: ``C_wr`` (and the bearing capacitance read from the divider ratio of each
record) is reported as identifiable only through the priors of the path inductance and of
the air-gap capacitance; where those priors are wide its 95 % interval is wide (often wider
than 100x: the paper's measurements do not fix the rotor-side scale; the Shaft-Frame
impedance of ``../shared/CONTRACT.md`` section 2a would).

K. M. Murphy, R. H. Topel, "Estimation and inference in two-step econometric models",
J. Business & Economic Statistics 3(4), 370-379, 1985.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vfmodel.greybox.identify import StageReport
from vfmodel.greybox.params import ParamSet
from vfmodel.greybox.priors import Prior

__all__ = ["PATH", "prior_second_moment", "with_path_prior"]

ArrF = NDArray[np.float64]

PATH = ("shaft.L_1", "shaft.L_2", "shaft.L_int", "ball.L_ext", "ball.L_int")
"""Inductances of the rotor current's path to the frame at standstill (the parameters
bounded by :data:`.assembly.PATH_L_MAX`). Their resistances are left to the data: at the
ringing frequencies (MHz) the path's reactance is ohms, its resistance milliohms."""


def prior_second_moment(priors: Mapping[str, Prior], params: ParamSet,
                        names: Sequence[str]) -> ArrF:
    """``M = E[(ln p - ln p_fit)(ln p - ln p_fit)^T]`` of ``names`` under their independent
    ``priors`` (``p_fit``: the values in ``params``): ``diag(sigma^2) + d d^T``, ``d`` the
    log medians (the log means of both kinds of prior) minus the fitted log values."""
    sig = np.array([priors[n].sigma for n in names])
    d = np.array([math.log(priors[n].median) - math.log(params[n]) for n in names])
    return np.asarray(np.diag(sig ** 2) + np.outer(d, d), dtype=float)


def with_path_prior(report: StageReport, params: ParamSet, priors: Mapping[str, Prior],
                    path: Sequence[str] = PATH, held: Sequence[str] = ()) -> StageReport:
    """``report`` (a machine stage) with the covariance of the module docstring: the
    ``path`` parameters it holds known only through ``priors``, the ``held`` parameters
    (in ``params``, not in the report) appended likewise. Returned unchanged without a
    covariance or when there is nothing to replace."""
    if report.cov_log is None:
        return report
    names = tuple(report.names)
    extra = tuple(n for n in held if n not in names and n in params and n in priors)
    n = len(names)
    pk = [k for k, nm in enumerate(names) if nm in path and nm in priors]
    if not pk and not extra:
        return report
    cov = np.pad(np.array(report.cov_log, dtype=float), ((0, len(extra)), (0, len(extra))))
    all_names = names + extra
    qk = pk + list(range(n, n + len(extra)))          # known through their priors
    m = prior_second_moment(priors, params, [all_names[k] for k in qk])
    seen = np.isfinite(np.diag(cov))
    seen &= np.all(np.isfinite(cov) | ~seen[None, :], axis=1)
    ok = [k for k in range(n) if seen[k]]
    p_ok = [k for k in pk if seen[k]]
    o_ok = [k for k in ok if k not in pk]
    new = cov.copy()
    # every covariance with a prior-known parameter is replaced (unseen path parameters
    # included: the data did not couple them to anything)
    new[qk, :] = 0.0
    new[:, qk] = 0.0
    new[np.ix_(qk, qk)] = m
    if p_ok and o_ok:
        f = np.linalg.pinv(cov[np.ix_(ok, ok)], hermitian=True)
        pos = {k: j for j, k in enumerate(ok)}
        io = [pos[k] for k in o_ok]
        ip = [pos[k] for k in p_ok]
        c_cond = np.linalg.pinv(f[np.ix_(io, io)], hermitian=True)
        # S for every prior-known parameter: zero for the held ones (not in the stage)
        s = np.zeros((len(o_ok), len(qk)))
        s[:, [qk.index(k) for k in p_ok]] = -c_cond @ f[np.ix_(io, ip)]
        new[np.ix_(o_ok, o_ok)] = c_cond + s @ m @ s.T
        new[np.ix_(o_ok, qk)] = s @ m
        new[np.ix_(qk, o_ok)] = (s @ m).T
    rel = np.sqrt(np.maximum(np.diag(new), 0.0))
    return StageReport(report.name, all_names, report.n_residuals, report.chi2_red,
                       report.nfev, report.status,
                       {k: float(v) for k, v in zip(all_names, rel, strict=True)}, new,
                       report.corr_factor)
