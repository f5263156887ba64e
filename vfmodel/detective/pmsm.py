"""The PMSM grey-box network as a detective family (``vfmodel diagnose DATASET --without``).

Starting network: the full model of the reference paper (every effect of the vocabulary
except ``fixture_inductance`` and ``endwinding_capacitance``, which the paper's network does
not have) minus the effects named with ``--without``; candidates:
every effect the starting network lacks, each at the one place of the network where it
applies (:data:`LOCATIONS`). The network is identified first by the staged grey-box
identification (:func:`vfmodel.greybox.identify.identify`: impedance spectra, standstill
H1, lubricant per speed) and then refitted jointly on every channel by the detective; an
accepted network whose effect explained at least half of the misfit is identified the same
way again (:meth:`PmsmFamily.restart`, called by ``detective.diagnose._restarted``) and the
better of that refit and the warm-started one kept.

Channels (the data the detective compares with):

- ``impedance:<topology>``: the six CM/DM spectra (thinned to ``fit_points``), noise
  from a black-box rational fit (:func:`vfmodel.detective.noise.spectrum_noise`);
- ``bearing:<rpm>rpm:<phase>``: the H1 transfer from each terminal voltage to the bearing
  voltage at each recorded speed, the model's output passed through the same estimator as
  the measurement (paper eq. 21, :class:`vfmodel.greybox.objective.BearingTerm`); noise:
  the random error of the H1 estimate from the coherence (no model-error floor);
- ``impedance:Shaft-Frame`` and ``impedance:Shaft-Frame@<rpm>rpm``: the shaft-to-frame
  spectra of CONTRACT section 2a when the dataset holds them (standstill and recorded
  speeds; :mod:`vfmodel.detective.shaft_frame`), after the records. The staged
  identification does not use them; the detective's fits do.
- ``bearing_de:<rpm>rpm:<phase>`` and ``i_cm:<rpm>rpm:<phase>``: the further recording
  channels ``u_B_DE`` and ``i_CM`` of CONTRACT section 2a when a recording carries them,
  treated as ``u_B`` is (:mod:`vfmodel.detective.record_channels`), last. Likewise only
  the detective's fits use them.

Parameters: the machine parameters of the standstill network (shared by every channel)
and, per rotating speed ``s``, a copy ``<name>@<s>rpm`` of each speed-dependent lubricant
parameter (film layers, contact resistance, edge capacitance; the paper identifies them
per speed). The standstill spectra and the 0 rpm recording share the base lubricant values
(fitted only when the starting network has no metallic contact: with it the film is
shorted at standstill).

Jacobians are analytic (adjoint MNA sensitivities chained through the H1 estimator, see
:mod:`vfmodel.greybox.objective`); :func:`vfmodel.detective.fit.refit` uses
:meth:`PmsmFamily.residual_jacobian` instead of forward differences.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel._choices import BearingState
from vfmodel.circuit.poles import network_poles
from vfmodel.core.dataset import Dataset
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.job_pool import JobPool
from vfmodel.core.progress import Progress, no_progress
from vfmodel.detective.film_law import FilmLaw, unrecorded_speed
from vfmodel.detective.noise import spectrum_noise
from vfmodel.detective.problem import Candidate, Channel, split_channels
from vfmodel.detective.record_channels import (
    RecordChannelTerm,
    record_terms,
    term_channels,
    term_residual,
)
from vfmodel.detective.shaft_frame import SHAFT_FRAME, PortTerm, local_names, speed_tag
from vfmodel.errors import InputError
from vfmodel.greybox.assembly import PHASES, TAPER_NAMES, default_params, lubricant_names
from vfmodel.greybox.effects import (
    ALL_EFFECTS,
    EFFECT_LOCATIONS,
    PAPER_EFFECTS,
    check_effects,
)
from vfmodel.greybox.identify import (
    bearing_state,
    identify,
    machine_names,
    thin_spectra,
)
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.objective import (
    BEARING_QUANTITY,
    BearingTerm,
    ImpedanceTerm,
    LogMap,
    PreparedRecording,
    RecordQuantity,
    bearing_term,
    impedance_term,
    log_map,
    prepare_recording,
)
from vfmodel.greybox.params import ParamSet, ParamSpec
from vfmodel.greybox.priors import Prior

__all__ = ["LOCATIONS", "PmsmFamily", "pmsm_family", "speed_tag"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]

LOCATIONS = EFFECT_LOCATIONS
"""Where in the network each effect applies (the ``location`` of a finding)."""

# every speed-dependent name of any structure (per-speed copies exist for all of them)
_LUB_ALL = lubricant_names(default_params())
# start values of a candidate's multistart: (parameter, values spread over the band)
_STARTS: dict[str, tuple[str, tuple[float, ...]]] = {
    "winding_skin_effect": ("winding.skin_l_frac", (0.02, 0.1, 0.4)),
    "insulation_dielectric_loss": ("insulation.tau_d", (1.6e-4, 1.6e-5, 1.6e-6, 1.6e-7)),
    "frame_skin_effect": ("frame.L_int", (1e-9, 4e-9, 2e-8)),
    "shaft_skin_effect": ("shaft.L_int", (2e-9, 1e-8, 5e-8)),
    "ball_skin_effect": ("ball.L_int", (2e-9, 1e-8, 5e-8)),
    "lubricant_dielectric_loss": ("lubricant.tau_d", (1.6e-5, 1.6e-6, 1.6e-7)),
    "lubricant_two_layer": ("lubricant.R_2", (30.0, 300.0, 3e3)),
    "hertzian_edge_capacitance": ("bearing.C_edge", (1e-10, 1e-9, 1e-8)),
    "fixture_inductance": ("fixture.L", (1e-9, 1e-8, 1e-7)),
    "endwinding_capacitance": ("winding.C_pp", (3e-12, 2e-11, 1e-10)),
}


def _structure(base: frozenset[str], applied: Sequence[Candidate]) -> frozenset[str]:
    return frozenset(base | {c.effect for c in applied})


@dataclass(frozen=True, eq=False)
class PmsmFamily:
    """Detective family of the PMSM grey-box network (see the module docstring)."""

    dataset_name: str
    base_effects: frozenset[str]
    n_rungs: int
    n_sections: int
    channels: tuple[Channel, ...]
    spectra: dict[str, FrequencyData]
    topologies: tuple[str, ...]
    imp_sigma: ArrF
    preps: tuple[PreparedRecording, ...]
    start: ParamSet
    _cands: tuple[Candidate, ...] = ()
    ports: tuple[PortTerm, ...] = ()    # shaft-to-frame spectra, channels after the records
    records: tuple[RecordChannelTerm, ...] = ()   # u_B_DE, i_CM: channels after the ports
    # compiled terms per structure (a memo of pure functions of the structure, not state)
    _memo: dict[frozenset[str], tuple[ImpedanceTerm | None, tuple[BearingTerm, ...]]] = \
        field(default_factory=dict, repr=False)
    _names: dict[frozenset[str], tuple[str, ...]] = field(default_factory=dict, repr=False)
    _lmaps: dict[tuple[frozenset[str], tuple[str, ...]], LogMap] = field(default_factory=dict,
                                                                         repr=False)
    # evaluation pools open now (evaluation_pool), per structure
    _pools: dict[frozenset[str], JobPool[Any]] = field(default_factory=dict, repr=False)
    # the staged identification of a structure (effects -> start values), see restart
    _identify: Callable[[frozenset[str]], ParamSet] | None = field(default=None, repr=False)
    # physical priors of the parameters (maximum a posteriori refits, detective.fit), or
    # None: least squares of the data alone
    priors: Mapping[str, Prior] | None = None
    # the film law across speeds (--film-law, :mod:`vfmodel.detective.film_law`): its
    # parameters replace the per-speed copies of the names it governs
    law: FilmLaw | None = None

    # ------------------------------------------------------------------ protocol
    @property
    def name(self) -> str:
        miss = sorted(PAPER_EFFECTS - self.base_effects)
        return ("PMSM grey-box network of the reference paper"
                + (f" without {', '.join(miss)}" if miss else "") + f" ({self.dataset_name})")

    def start_params(self) -> ParamSet:
        return self.start

    def candidates(self) -> tuple[Candidate, ...]:
        return self._cands

    def spec(self, applied: Sequence[Candidate] = ()) -> NetSpec:
        return NetSpec(_structure(self.base_effects, applied), self.n_rungs, self.n_sections)

    def free_names(self, applied: Sequence[Candidate], params: ParamSet) -> tuple[str, ...]:
        eff = _structure(self.base_effects, applied)
        if eff not in self._names:
            self._names[eff] = self._free(eff, params)
        return self._names[eff]

    def _free(self, eff: frozenset[str], params: ParamSet) -> tuple[str, ...]:
        spec = NetSpec(eff, self.n_rungs, self.n_sections)
        # the insulation tapers are not refitted: they keep the values the identification
        # found (the start); the candidates' decisions were calibrated without them
        names = [n for n in machine_names(params, spec) if n not in TAPER_NAMES]
        lub = lubricant_names(params, eff)
        if bearing_state(0.0, eff) == "rotating":     # no contact: the film is seen at rest
            names += [n for n in lub if n not in names]
        per_speed = lub
        if self.law is not None:
            names += [n for n in self.law.law_names(lub) if n not in names]
            per_speed = tuple(n for n in lub if not self.law.governed(n))
        for p in self.preps:
            if p.speed_rpm > 0:
                names += [n + speed_tag(p.speed_rpm) for n in per_speed]
        return tuple(names)

    def free_description(self) -> PmsmFamily:
        """The same family with free per-speed film values (no law; the compiled terms
        shared)."""
        return replace(self, law=None, _names={}, _pools={})

    def restart(self, applied: Sequence[Candidate], params: ParamSet) -> ParamSet | None:
        """Start values for the network ``applied`` from the staged identification of that
        structure (:func:`vfmodel.greybox.identify.identify`, the same sections), on the
        names of ``params``; None when the family was built without it.

        A finding can change the network so much that a warm-started refit from the old
        optimum stays in its valley: on the concealed case ``pmsm_contact_x`` (metallic
        contact concealed, Shaft-Frame spectra measured) the network without the contact
        had bent the machine values towards the standstill Shaft-Frame spectrum, and after
        the contact was added the six spectra stayed at 100-190 per residual (chi2_red
        56.7), so a decoy was accepted next."""
        if self._identify is None:
            return None
        got = self._identify(_structure(self.base_effects, applied))
        keep = {n: got[n] for n in got.names if n in params}
        return params.with_values(keep, clip=True)   # (law: got holds its law start)

    def state(self, rpm: float, applied: Sequence[Candidate] = ()) -> BearingState:
        return bearing_state(rpm, _structure(self.base_effects, applied))

    def at_speed(self, params: ParamSet, rpm: float) -> ParamSet:
        """Parameters of the network at ``rpm`` (per-speed lubricant copies substituted).

        With the film law, also at a rotating speed that was not recorded (a recommended
        recording, :mod:`vfmodel.detective.recommend`): the governed values from the law,
        the other speed-dependent ones from a power law through their recorded copies
        (:func:`vfmodel.detective.film_law.unrecorded_speed`)."""
        if rpm <= 0:
            return params
        tag = speed_tag(rpm)
        vals = {n: params[n + tag] for n in _LUB_ALL if n + tag in params}
        if self.law is not None and rpm not in self.law.speeds:
            vals = unrecorded_speed(self.law, params, _LUB_ALL, rpm)
        elif self.law is not None:        # the governed values from the law
            vals.update({n: v for n, v in self.law.values_at(params, rpm).items()
                         if n + tag in params})
        return params.with_values(vals, clip=True)

    def _terms(self, applied: Sequence[Candidate], params: ParamSet
               ) -> tuple[ImpedanceTerm | None, tuple[BearingTerm, ...]]:
        eff = _structure(self.base_effects, applied)
        if eff not in self._memo:
            spec = NetSpec(eff, self.n_rungs, self.n_sections)
            imp = impedance_term(self.spectra, spec, params,
                                 self.topologies) if self.topologies else None
            bts = tuple(_bearing_term(p, spec, self.at_speed(params, p.speed_rpm),
                                      bearing_state(p.speed_rpm, eff)) for p in self.preps)
            self._memo[eff] = (imp, bts)
        return self._memo[eff]

    def _lmap(self, applied: Sequence[Candidate], params: ParamSet,
              names: Sequence[str]) -> LogMap:
        """Parameter-to-element-value map of the structure (computed once per structure
        and parameter list; its non-constant columns are re-evaluated at each call)."""
        eff = _structure(self.base_effects, applied)
        key = (eff, tuple(names))
        if key not in self._lmaps:
            self._lmaps[key] = log_map(params, names, NetSpec(eff, self.n_rungs,
                                                              self.n_sections))
        return self._lmaps[key]

    def predict(self, applied: Sequence[Candidate], params: ParamSet) -> list[ArrC]:
        imp, bts = self._terms(applied, params)
        out: list[ArrC] = []
        if imp is not None:
            z = imp.model(params)
            out += [z[:, i] for i in range(z.shape[1])]
        for bt, p in zip(bts, self.preps, strict=True):
            h = bt.h1_model(self.at_speed(params, p.speed_rpm))
            out += [h[:, i] for i in range(h.shape[1])]
        out += [t.model(self, applied, params) for t in self.ports]
        for rt in self.records:
            out += rt.model(self, applied, params)
        return out

    def residual(self, applied: Sequence[Candidate], params: ParamSet) -> ArrF:
        """Noise-normalised residual (layout of :mod:`.problem`)."""
        return self._residual(applied, params, None)[0]

    def residual_jacobian(self, applied: Sequence[Candidate], params: ParamSet,
                          names: Sequence[str]) -> tuple[ArrF, ArrF]:
        """Residual and its derivative with respect to ``log`` of ``names`` (analytic);
        with the film law, ``J_speed @ A`` (:meth:`FilmLaw.expand`)."""
        if self.law is None:
            r, j = self._residual(applied, params, tuple(names))
            assert j is not None
            return r, j
        net, a = self.law.expand(names, params)
        r, j = self._residual(applied, params, net)
        assert j is not None
        return r, j @ a

    def _residual(self, applied: Sequence[Candidate], params: ParamSet,
                  names: tuple[str, ...] | None) -> tuple[ArrF, ArrF | None]:
        imp, bts = self._terms(applied, params)
        jobs = self._jobs(imp, bts)
        pool = self._pools.get(_structure(self.base_effects, applied))
        if pool is not None:
            # the record transfers (eigenvalues, ~50 ms each) and Jacobians (adjoint solves
            # on ~350 frequencies, ~0.1 s each) dominate an evaluation: the terms run side
            # by side in the pool's workers; their transfers come back to the memos here
            parts = pool.map((params, names))
            for k, pr in zip(jobs, parts, strict=True):
                if k >= 0 and pr[2] is not None:
                    self._record_term(applied, params, k)._memo.restore(pr[2])
        else:
            parts = [self._part(applied, params, names, k) for k in jobs]
        nb = len(parts) - len(self.records)     # the further record channels come last
        rs = [r for pr in parts[:nb] for r in pr[0]]
        js = [j for pr in parts[:nb] for j in pr[1]]
        for port in self.ports:         # further impedances (Shaft-Frame): small, here
            r, jm = port.residual(self, applied, params, names)
            rs.append(r)
            if names is not None:
                assert jm is not None
                js.append(jm)
        rs += [r for pr in parts[nb:] for r in pr[0]]
        js += [j for pr in parts[nb:] for j in pr[1]]
        return np.concatenate(rs), (np.concatenate(js) if names is not None else None)

    def _jobs(self, imp: ImpedanceTerm | None, bts: Sequence[BearingTerm]) -> list[int]:
        """Terms of an evaluation: -1 the impedances, ``0 .. len(bts) - 1`` the u_B records,
        then the further record channels (:attr:`records`)."""
        return ([-1] if imp is not None else []) + list(range(len(bts) + len(self.records)))

    def _record_term(self, applied: Sequence[Candidate], params: ParamSet, k: int
                     ) -> BearingTerm:
        """The record term of job ``k >= 0`` (a u_B record or a further record channel)."""
        bts = self._terms(applied, params)[1]
        if k < len(bts):
            return bts[k]
        return self.records[k - len(bts)].term(self, applied, params)

    @contextmanager
    def evaluation_pool(self, applied: Sequence[Candidate], params: ParamSet,
                        names: Sequence[str] = ()) -> Iterator[None]:
        """Within the block, evaluations of the network ``applied`` run their terms (the
        impedances, each record) in persistent worker processes (:class:`JobPool`: forked
        once; a term moves to another worker only when the measured times deal the terms
        anew, :meth:`JobPool.map`). The terms and the log maps of ``names`` (the fitted
        parameters) are made here first, at ``params``, so that the workers inherit them
        and every fit uses the maps of the first one (as in sequence)."""
        key = _structure(self.base_effects, applied)
        imp, bts = self._terms(applied, params)
        jobs = self._jobs(imp, bts)
        for k in jobs[len(jobs) - len(self.records):]:
            self._record_term(applied, params, k)       # compiled here, inherited
        if names and self.law is not None:      # the network names the law's map reaches
            names = self.law.expand(names, params)[0]
        if names:
            for k in jobs:
                self._part_names(applied, params, tuple(names), k)
        if key in self._pools or len(jobs) < 2:
            yield
            return

        def job(i: int, arg: tuple[ParamSet, tuple[str, ...] | None]
                ) -> tuple[list[ArrF], list[ArrF], tuple[bytes, ArrC] | None]:
            return self._part(applied, arg[0], arg[1], jobs[i])

        with JobPool(job, len(jobs)) as pool:
            if not pool.processes:
                yield
                return
            self._pools[key] = pool
            try:
                yield
            finally:
                del self._pools[key]

    def _part_names(self, applied: Sequence[Candidate], params: ParamSet,
                    names: tuple[str, ...], k: int) -> tuple[list[str], list[int]]:
        """Local parameter names of term ``k`` (-1: the impedances; from ``len(preps)`` on
        the further record channels) and their columns; builds the term's log map."""
        if k < 0:
            loc, cols = local_names(names, 0.0, params)
            if loc:
                self._lmap(applied, params, loc)
            return loc, cols
        rpm = self.preps[k].speed_rpm if k < len(self.preps) else \
            self.records[k - len(self.preps)].speed_rpm
        loc, cols = local_names(names, rpm, params)
        if loc:
            self._lmap(applied, self.at_speed(params, rpm), loc)
        return loc, cols

    def _part(self, applied: Sequence[Candidate], params: ParamSet,
              names: tuple[str, ...] | None, k: int
              ) -> tuple[list[ArrF], list[ArrF], tuple[bytes, ArrC] | None]:
        """Residual channels (and Jacobian blocks) of term ``k`` (-1: the impedances; from
        ``len(preps)`` on the further record channels), and the record term's memo entry
        (None for the impedances)."""
        jac = names is not None
        nn = names or ()
        imp, bts = self._terms(applied, params)
        if k >= len(bts):               # a further record channel (u_B_DE, i_CM)
            rt = self.records[k - len(bts)]
            r3, j3 = rt.residual(self, applied, params, names)
            return r3, j3, rt.term(self, applied, params)._memo.entry()
        if k < 0:
            assert imp is not None
            loc, cols = self._part_names(applied, params, nn, k) if jac else ([], [])
            nt = len(self.topologies)
            nf = imp.freq_hz.size
            if loc:
                r, jm = imp.residual(params, loc, jac=True,
                                     lmap=self._lmap(applied, params, loc))
                assert jm is not None
            else:
                r, jm = imp.residual(params)[0], np.zeros((2 * nf * nt, 0))
            scale = np.tile(imp.sigma / self.imp_sigma, 2 * nf)    # term sigma -> detective
            rs, js = split_channels(r * scale, jm * scale[:, None] if jac else None, nf, nt,
                                    cols, len(nn))
            return rs, js, None
        bt = bts[k]
        rs, js = term_residual(self, bt, applied, params, self.preps[k].speed_rpm, names)
        return rs, js, bt._memo.entry()

    def poles(self, applied: Sequence[Candidate], params: ParamSet) -> ArrC:
        spec = self.spec(applied)
        return network_poles(spec.build(params, bearing_state(0.0, spec.effects)))

    # ------------------------------------------------------------------ extras
    def bearing_terms(self) -> tuple[BearingTerm, ...]:
        """Bearing terms of the starting structure, one per recording (measured H1, its
        frequency grid and whitening; :mod:`vfmodel.detective.recommend` uses them)."""
        return self._terms((), self.start)[1]

    def outputs(self, applied: Sequence[Candidate], params: ParamSet) -> list[ArrF]:
        """Modelled bearing voltage (periodic steady state) of every recording."""
        _, bts = self._terms(applied, params)
        return [bt.output(self.at_speed(params, p.speed_rpm))
                for bt, p in zip(bts, self.preps, strict=True)]

    def bearing_rel_err_pct(self, fit: object) -> float:
        """Mean over recordings of the relative peak error of the filtered bearing voltage."""
        if not self.preps:
            return float("nan")
        ys = self.outputs(fit.applied, fit.params)  # type: ignore[attr-defined]
        errs = [abs(float(np.max(np.abs(y))) - float(np.max(np.abs(p.bearing))))
                / float(np.max(np.abs(p.bearing))) * 100 for y, p in zip(ys, self.preps,
                                                                       strict=True)]
        return float(np.mean(errs))


BEARING_F_MAX_HZ = 2e6
"""Upper end of the bearing H1 band the detective tests (why: ``docs/notes.md``, "Detective:
bearing band and bin step")."""


BEARING_BIN_STEP = 2
"""The detective tests every second H1 bin (why: ``docs/notes.md``, "Detective: bearing
band and bin step")."""


def _bearing_term(prep: PreparedRecording, spec: NetSpec, params: ParamSet,
                  state: BearingState,
                  quantity: RecordQuantity = BEARING_QUANTITY) -> BearingTerm:
    """Condition-2 term of the detective: no model-error floor, the three components of
    each H1 bin whitened by the estimate's full covariance (unit variance under the null
    hypothesis), the input-noise bias of H1 modelled where the record allows it, bins up
    to :data:`BEARING_F_MAX_HZ`, every :data:`BEARING_BIN_STEP`-th bin. ``quantity``: what
    ``prep`` measures (u_B; the further record channels, :mod:`.record_channels`)."""
    return bearing_term(prep, spec, params, state, f_max_hz=BEARING_F_MAX_HZ,
                        model_error=0.0, weighting="covariance", input_noise=True,
                        bin_step=BEARING_BIN_STEP, quantity=quantity)


def _candidate(effect: str, base: ParamSet, family: PmsmFamily) -> Candidate:
    """``effect`` at its place with the parameters it frees and a multistart."""
    eff0 = family.base_effects
    spec_map = {s.name: s for s in base.specs}
    before = set(family._free(eff0, base))
    after = family._free(frozenset(eff0 | {effect}), base)
    new = tuple(spec_map[n] for n in after if n not in before)
    starts: tuple[tuple[tuple[str, float], ...], ...] = ()
    if effect in _STARTS:
        pname, vals = _STARTS[effect]
        targets = [n for n in after if n == pname or n.startswith(pname + "@")]
        starts = tuple(tuple((n, v) for n in targets) for v in vals)
    return Candidate(effect, LOCATIONS[effect], new, starts)


def _with_speed_copies(params: ParamSet, speeds: Iterable[float]) -> ParamSet:
    specs = {s.name: s for s in params.specs}
    extra = []
    for rpm in speeds:
        if rpm <= 0:
            continue
        for n in _LUB_ALL:
            s = specs[n]
            extra.append(ParamSpec(n + speed_tag(rpm), s.nominal, s.lower, s.upper,
                                   f"speed {rpm:g} rpm", s.unit, s.description))
    return params.with_specs(extra)


_DECADES = 4.0  # span of the six spectra assumed when a dataset has none (1 kHz-10 MHz)


def _decades(fd: FrequencyData) -> float:
    """Decades a spectrum spans (0 for fewer than two positive frequencies)."""
    f = fd.freq_hz[fd.freq_hz > 0]
    return max(float(np.log10(f[-1] / f[0])), 0.0) if f.size > 1 else 0.0


def _span_points(fd: FrequencyData, fit_points: int, decades: float = _DECADES) -> int:
    """Points kept of a Shaft-Frame spectrum: ``fit_points`` per ``decades`` (the six
    spectra's span), so that a wider band keeps the density of the six spectra (a
    1 kHz-100 MHz spectrum of 251 points kept 84 of them, 17 per decade against 25: the
    networks' features above 10 MHz fell between every second point, and refits on the
    even points were free to move them, which the held-out test then scored)."""
    return max(fit_points, int(np.ceil(fit_points * _decades(fd) / max(decades, 1e-12))))


def _ports(dataset: Dataset, fit_points: int, speeds: set[float], progress: Progress,
           decades: float = _DECADES) -> list[tuple[PortTerm, str, ArrC | None]]:
    """Shaft-to-frame spectra of the dataset (CONTRACT section 2a) as detective terms, with
    their noise method and black-box poles: the standstill one, and those at the recorded
    speeds (another speed has no per-speed lubricant values to predict it with)."""
    spectra: dict[float, FrequencyData] = {}
    if SHAFT_FRAME in dataset.further_impedance:
        spectra[0.0] = dataset.further_impedance[SHAFT_FRAME]
    for s in dataset.impedance_at_speed:
        if s.topology == SHAFT_FRAME and float(s.speed_rpm) in speeds:
            spectra[float(s.speed_rpm)] = s.data
    out = []
    for k, (rpm, fd) in enumerate(sorted(spectra.items())):
        progress("noise of the shaft-to-frame spectra", k, len(spectra))
        full = fd.to_kind("Z")
        nz = spectrum_noise(full.freq_hz, full.values[:, 0, 0])
        thin = thin_spectra({SHAFT_FRAME: full},
                            _span_points(full, fit_points, decades))[SHAFT_FRAME]
        where = f"impedance:{SHAFT_FRAME}" + (speed_tag(rpm) if rpm > 0 else "")
        out.append((PortTerm(where, rpm, thin.freq_hz, thin.values[:, 0, 0], nz.sigma),
                    nz.method, None if nz.blackbox is None else nz.blackbox.poles))
    return out


def pmsm_family(dataset: Dataset, without: Iterable[str] = (), *, fit_points: int = 101,
                n_rungs: int = 3, sections: Sequence[int] = (2, 3, 4),
                priors: bool = False, film_law: bool = False,
                progress: Progress = no_progress) -> PmsmFamily:
    """Identify the starting network on ``dataset`` and build the family.

    ``without``: effects of the paper's model left out of the starting network;
    ``fit_points``: points per impedance spectrum used by the detective; ``priors``: the
    staged identification of the start and the detective's refits are maximum a
    posteriori with the physical priors of the starting network's parameters
    (:func:`vfmodel.greybox.priors.parameter_priors` with the dataset's
    ``[machine]``/``[bearing]``/``[priors]`` tables; a per-speed copy takes the prior at
    its speed, :func:`vfmodel.detective.identifiability.grey_box_priors`); a candidate
    effect's own parameters stay free (its presence is what the detective tests), and so
    do the film law's; ``film_law``:
    the film follows a law in speed (:mod:`vfmodel.detective.film_law`; needs recordings
    at two or more rotating speeds, else :class:`InputError`), its start values fitted to
    the staged identification's per-speed values.
    """
    wo = check_effects(without, "--without")
    bad = wo - PAPER_EFFECTS
    if bad:
        raise InputError("--without names effects that the starting model does not have",
                         place="--without", found=", ".join(sorted(bad)),
                         expected="effects of the paper's model: "
                                  + ", ".join(sorted(PAPER_EFFECTS)))
    if not dataset.impedance and not dataset.recordings:
        raise InputError("dataset holds neither impedance spectra nor recordings",
                         source=dataset.name)
    base = frozenset(PAPER_EFFECTS - wo)
    recs = sorted(dataset.recordings, key=lambda r: float(r.speed_rpm or 0.0))
    law = FilmLaw(tuple(float(r.speed_rpm or 0.0) for r in recs)) if film_law else None
    preps = []
    for k, r in enumerate(recs):
        progress("prepare recordings", k, len(recs))
        preps.append(prepare_recording(r))
    progress("prepare recordings", len(recs), len(recs))
    prepared = {p.speed_rpm: p for p in preps}
    # the further record channels (u_B_DE, i_CM) prepared before the identification: a
    # flat channel is refused before minutes of work
    records = record_terms(recs, preps, _bearing_term)

    def identified(effects: frozenset[str], secs: Sequence[int],
                   prog: Progress = no_progress) -> tuple[ParamSet, int]:
        # the detective scores the recordings by their H1 transfers (_bearing_term): its
        # start fits the standstill record the same way
        ident = identify(dataset, effects, sections=secs, n_rungs=n_rungs, prepared=prepared,
                         progress=prog, standstill_fit="h1", priors=priors)
        st = _with_speed_copies(ident.params, prepared)
        vals: dict[str, float] = {}
        for sf in ident.speeds:
            if sf.speed_rpm > 0:
                vals.update({n + speed_tag(sf.speed_rpm): sf.params[n] for n in _LUB_ALL})
        st = st.with_values(vals, clip=True)
        if law is not None:
            st = law.start(st.with_specs(law.specs(st)))
        return st, ident.spec.n_sections

    start, n_sec = identified(base, sections, progress)
    # detective channels
    spectra = thin_spectra(dataset.impedance, fit_points) if dataset.impedance else {}
    topo = tuple(t for t in spectra)
    chans: list[Channel] = []
    sig = []
    for k, t in enumerate(topo):
        progress("noise of the spectra", k, len(topo))
        fd = spectra[t].to_kind("Z")
        z = fd.values[:, 0, 0]
        nz = spectrum_noise(dataset.impedance[t].freq_hz,
                            dataset.impedance[t].to_kind("Z").values[:, 0, 0])
        sig.append(nz.sigma)
        chans.append(Channel(f"impedance:{t}", fd.freq_hz, z, np.full(z.size, nz.sigma),
                             nz.method, None if nz.blackbox is None else nz.blackbox.poles))
    progress("noise of the spectra", len(topo), len(topo))
    fam = PmsmFamily(dataset.name, base, n_rungs, n_sec, (), dict(spectra),
                     topo, np.asarray(sig, dtype=float), tuple(preps), start,
                     _identify=lambda eff: identified(eff, (n_sec,))[0], law=law)
    # the bearing channels are those of the starting structure's terms (built once, kept)
    _, bts = fam._terms((), start)
    for p, bt in zip(preps, bts, strict=True):
        chans += term_channels(bt, [f"bearing:{p.speed_rpm:g}rpm:{ph}" for ph in PHASES])
    span = max((_decades(fd) for fd in dataset.impedance.values()), default=0.0) or _DECADES
    ports = _ports(dataset, fit_points, {p.speed_rpm for p in preps}, progress, span)
    chans += [Channel(t.where, t.freq_hz, t.z_meas, np.full(t.freq_hz.size, t.sigma), m, bb)
              for t, m, bb in ports]
    for k, rt in enumerate(records):
        progress("further record channels", k, len(records))
        chans += rt.channels(fam, start)
    # shares the memo of compiled terms
    fam = replace(fam, channels=tuple(chans), ports=tuple(t for t, _, _ in ports),
                  records=tuple(records))
    cands = tuple(_candidate(e, start, fam) for e in sorted(ALL_EFFECTS - base))
    pri = None
    if priors:
        from vfmodel.detective.identifiability import grey_box_priors

        # the starting network's parameters only: a candidate's size stays free, so that
        # the network with it contains the one without (a log-normal prior on the size
        # would make the effect's absence cost prior chi-square: on pmsm_edge, seed 0, the
        # candidates' MAP refits ended Delta chi2 +1.5..+4.7 above the network without)
        pri = grey_box_priors(sorted(fam.free_names((), start)), dataset)
    return replace(fam, _cands=cands, priors=pri)

