"""Effect vocabulary of the grey-box bearing-voltage model (CONTRACT section 7).

Each effect is a switch of :func:`vfmodel.greybox.assembly.build_network`: with the effect
the network contains the substructure listed in ``adds``; without it a simpler one (or
nothing). :data:`EFFECT_INFO` holds, per effect, the physics explanation written into a
``diagnosis.json`` finding, the residual signature the detective looks for, where in the
network it applies, and the parameters (names of :mod:`vfmodel.greybox.params`) that only
exist with the effect.

References
----------
Reference paper (grey-box bearing-voltage model of a 40-kW PMSM), Sec. III, Figs. 12-17;
the RL skin-effect ladder follows its ref. [43].
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import get_args

from vfmodel._choices import Effect, check_choice

__all__ = ["ALL_EFFECTS", "EFFECT_INFO", "EFFECT_LOCATIONS", "JOINT_REFIT", "LUBRICANT_MAX_NFEV",
           "LUBRICANT_RANDOM_STARTS", "PAPER_EFFECTS", "SECTIONS", "EffectInfo",
           "check_effects"]


@dataclass(frozen=True)
class EffectInfo:
    """Vocabulary entry of one effect.

    Attributes
    ----------
    name : Effect
    adds : str
        What the effect adds to the network (CONTRACT section 7 wording).
    explanation : str
        One or two sentences of physics for a finding.
    signature : str
        Residual signature in the data when the effect is missing from the model.
    locations : tuple of str
        Where it applies (network location labels, also used as finding ``location``).
    where : tuple of str
        Data where the residual shows: ``"impedance:CM"``, ``"impedance:DM"``,
        ``"bearing:standstill"``, ``"bearing:rotating"``.
    band_hz : tuple of float
        Frequency band where the signature is expected.
    params : tuple of str
        Parameter names that exist only with the effect.
    """

    name: Effect
    adds: str
    explanation: str
    signature: str
    locations: tuple[str, ...]
    where: tuple[str, ...]
    band_hz: tuple[float, float]
    params: tuple[str, ...]


_LADDER = ("L_int", "rho")

EFFECT_INFO: dict[str, EffectInfo] = {
    e.name: e
    for e in (
        EffectInfo(
            "winding_skin_effect",
            "RL ladder in the winding branches (skin and proximity effect)",
            "Skin and proximity effect push the winding current to the conductor surface "
            "at high frequency, so the winding resistance rises roughly with sqrt(f) while "
            "its internal inductance falls; a plain R-L underestimates the damping of the "
            "winding resonances.",
            "CM and DM impedance: resonance peaks too sharp/too high and the inductive "
            "slope too steep above ~10 kHz in the model; real part of Z too small.",
            ("winding.U", "winding.V", "winding.W"),
            ("impedance:CM", "impedance:DM"),
            (1e4, 1e7),
            ("winding.skin_l_frac", "winding.skin_rho"),
        ),
        EffectInfo(
            "insulation_dielectric_loss",
            "series-RC dielectric-loss branch in insulation and air-gap paths (Fig. 13)",
            "Polarisation of the slot and phase insulation (and the air-gap dielectric) "
            "adds a relaxation branch, so the insulation capacitance decreases with "
            "frequency and the CM impedance phase stays a few degrees above -90 degrees.",
            "CM impedance below the first resonance: magnitude slope shallower than -20 "
            "dB/decade and phase above -90 degrees; small capacitance mismatch at 1 kHz.",
            ("insulation.winding-frame", "insulation.winding-rotor", "airgap"),
            ("impedance:CM",),
            (1e3, 1e6),
            ("insulation.k_d", "insulation.tau_d"),
        ),
        EffectInfo(
            "frame_skin_effect",
            "RL ladder (Fig. 14) for the stator frame instead of a plain R-L",
            "The frame is a massive conductor: at high frequency the CM return current "
            "flows in a thin surface layer, raising the frame resistance and lowering its "
            "internal inductance.",
            "CM impedance near and above the highest resonance (MHz) and the damping of "
            "the standstill bearing-voltage ringing.",
            ("frame",),
            ("impedance:CM", "bearing:standstill"),
            (1e6, 1e7),
            tuple(f"frame.{p}" for p in _LADDER),
        ),
        EffectInfo(
            "shaft_skin_effect",
            "RL ladders for the shaft segments instead of plain R-L",
            "The shaft carries the rotor current to the bearings; its skin effect makes the "
            "shaft impedance rise with sqrt(f) and damps the shaft-bearing ringing.",
            "Bearing voltage at standstill: ringing amplitude and decay in the MHz range.",
            ("shaft.1", "shaft.2"),
            ("bearing:standstill", "bearing:rotating"),
            (1e6, 1e7),
            tuple(f"shaft.{p}" for p in _LADDER),
        ),
        EffectInfo(
            "ball_skin_effect",
            "RL ladder for the bearing balls / contact conduction",
            "In the balls and at the Hertzian contact the conducting cross-section shrinks "
            "with the skin depth, so the contact path is a frequency-dependent R-L rather "
            "than a constant one.",
            "Bearing voltage at standstill (metallic contact): ringing damping and its "
            "high-frequency content.",
            ("bearing.DE", "bearing.NDE"),
            ("bearing:standstill",),
            (1e6, 1e7),
            tuple(f"ball.{p}" for p in _LADDER),
        ),
        EffectInfo(
            "lubricant_dielectric_loss",
            "third (series-RC) branch of the lubricant layer",
            "The lubricant is a lossy dielectric: polarisation of the oil and additives "
            "adds a relaxation branch, so the film capacitance falls with frequency.",
            "Bearing voltage when rotating: BVR magnitude decreasing with frequency "
            "between ~10 kHz and 1 MHz; plateau tilted.",
            ("bearing.DE.lubricant", "bearing.NDE.lubricant"),
            ("bearing:rotating",),
            (1e4, 1e6),
            ("lubricant.k_d", "lubricant.tau_d"),
        ),
        EffectInfo(
            "lubricant_two_layer",
            "base-oil film and thickener-rich layer in series (oil bleeding, layer separation)",
            "Oil bleeding out of the grease thickener separates the film into a base-oil "
            "layer and a thickener-rich layer of different permittivity and conductivity; "
            "two RC layers in series give a second relaxation in the bearing impedance.",
            "Bearing voltage when rotating: a step in the BVR magnitude (two plateaus) "
            "between ~10 kHz and a few MHz that one RC layer cannot follow.",
            ("bearing.DE.lubricant", "bearing.NDE.lubricant"),
            ("bearing:rotating",),
            (1e4, 3e6),
            ("lubricant.R_2", "lubricant.C_2"),
        ),
        EffectInfo(
            "hertzian_edge_capacitance",
            "capacitor across the contact for lubricant/air at the edge of the Hertzian zone",
            "Around the Hertzian contact the gap between ball and race widens slowly; the "
            "lubricant and air there form a capacitance in parallel with the contact that "
            "conducts even when the contact itself is shorted or the film is thick.",
            "Bearing voltage: BVR level when rotating and the ringing frequency at "
            "standstill.",
            ("bearing.DE", "bearing.NDE"),
            ("bearing:rotating", "bearing:standstill"),
            (1e5, 1e7),
            ("bearing.C_edge",),
        ),
        EffectInfo(
            "metallic_contact",
            "boundary-lubrication switch: metallic ball-race contact at standstill",
            "At standstill the bearing runs in boundary lubrication: metallic contact "
            "between balls and races shorts the film, so the shaft is held near frame "
            "potential and only switching-induced ringing remains.",
            "Bearing voltage at standstill: the model shows a square-wave film charging "
            "(capacitive divider) where the data settle to ~0 between switching events.",
            ("bearing.DE", "bearing.NDE"),
            ("bearing:standstill",),
            (0.0, 1e5),
            (),
        ),
        EffectInfo(
            "endwinding_capacitance",
            "capacitors between the phase terminals (end-winding phase-to-phase coupling)",
            "The line-end coils of adjacent phases face each other in the end windings and "
            "in the terminal box; their capacitance couples the terminals directly, in "
            "parallel with the windings, which the paper's per-phase network (capacitances "
            "to frame and rotor only) lacks.",
            "DM impedance above the first resonance (terminal-to-terminal capacitance "
            "that no CM value can give without spoiling the CM spectra) and the high "
            "band of the bearing transfer.",
            ("winding.terminals",),
            ("impedance:DM", "impedance:CM"),
            (1e5, 1e7),
            ("winding.C_pp",),
        ),
        EffectInfo(
            "fixture_inductance",
            "series lead/fixture inductance of the impedance measurement (outside the machine)",
            "The leads and fixture of the impedance analyser add a series inductance to "
            "every measured spectrum; it is not part of the machine.",
            "All impedance spectra: an extra inductive rise proportional to f at the top "
            "of the band (above the last resonance), the same in every topology.",
            ("fixture",),
            ("impedance:CM", "impedance:DM"),
            (1e6, 1e7),
            ("fixture.L",),
        ),
    )
}

ALL_EFFECTS: frozenset[str] = frozenset(get_args(Effect))
PAPER_EFFECTS: frozenset[str] = ALL_EFFECTS - {"fixture_inductance", "endwinding_capacitance"}
"""The full grey-box model of the reference paper: every effect except the fixture and the
end-winding phase-to-phase capacitance (beyond the paper's network, Fig. 12; like the
fixture never in the detective's starting model, always one of its candidates)."""

SECTIONS = (2, 3, 4, 5, 6)
"""Default candidate numbers of winding sections per phase (``identify``, ``reproduce``,
the CLI's ``--sections``; the next is tried only while the previous one lowered the
spectra's reduced chi-square by more than ``min_gain``, the lowest is kept). Up to 4 until
2026-11-24; on unseen independent benches 110, 111, 113, 114 (5-8 coils per phase) the
spectra's chi2 still fell 19/44/23/28 % from 4 to 5 sections, and with 4 the rotating
records of bench 113 could not be fitted (lubricant chi2 ~1e4, peak errors up to 55 %;
with up to 6: chi2 <= 13, errors <= 2.3 %). A machine that needs fewer stops earlier
(data/pmsm40kw: 4)."""

LUBRICANT_MAX_NFEV = 100
"""Evaluation limit of each start of a lubricant stage in ``reproduce`` and the CLI (the machine
stages keep ``max_nfev``, 40). A lubricant stage moves only the film of one speed (a
handful of parameters, each evaluation a low-rank update of the network), so its
evaluations are cheap, and stopped at 40 the stages that had not converged left single
speeds 4-7 % off while their neighbours were within 1-2 % (``scripts/bench_fidelity.py
--max-nfev-lubricant 40`` against the default, session 22):

- independent bench 112, 500 rpm: 6.82 -> 0.99 %; bench 131, 300 rpm: 2.69 -> 0.90 %
  (the BVR model's 1.83 % now beaten); benches 103, 111, 119 within 0.04 points;
- fresh benches 200-207 with the end-winding capacitance: bench 206 at 300 rpm chi2_red
  98 -> 57 and 4.37 -> 1.44 %, bench 202 at 300 rpm 4.67 -> 0.67 %; worst speed 4.67 ->
  2.34 %, mean 1.07 -> 0.89 %;
- ``data/pmsm40kw``: rotating mean 0.262 -> 0.255 %, the other figures unchanged.

A stage whose starts all converge (status 2) within 40 evaluations is not changed.
Raising every stage's limit to 100 instead made the 28 older benches worse (docs/notes.md,
session 21): the machine stages keep 40."""

LUBRICANT_RANDOM_STARTS = 4
"""Random starts added to each lubricant stage in ``reproduce`` and the CLI
(``vfmodel.greybox.identify._lubricant_starts``: the warm start with every film value
scaled by ``exp(sigma N(0, 1))``, ``sigma`` = ``identify.LUBRICANT_RANDOM_SIGMA``,
seeded, the same draws at every speed), beside the three physical starts. The film's fit
has basins the physical starts miss: regenerated independent bench 112 at 400 rpm ended
after 3 evaluations at chi2_red 37.7 and 6.36 % peak error from the best of those, at
25.9 and 1.98 % from a random start (300 rpm: 25.7 -> 24.4, 1.88 -> 0.40 %); bench 131
at 200 rpm 26.0 -> 25.7, 1.83 -> 1.34 %; bench 111 at 300 rpm 3.81 -> 0.66 %, fresh
benches 203 at 400 rpm 5.28 -> 1.32 % and 204 at 200 rpm 2.05 -> 1.22 %; no speed of 11
benches worse by more than 0.05 points (session 22, ``scripts/bench_fidelity.py
--lubricant-random-starts 0`` against the default). Cost: ``reproduce data/pmsm40kw``
34.7 -> 57.5 s idle (rotating mean 0.255 -> 0.244 %)."""

JOINT_REFIT = False
"""Default of ``reproduce --joint``: refit the rotor-side capacitances and the rotor-current
path with every rotating record (``identify(joint=True, joint_trigger=0)``,
:mod:`vfmodel.greybox.joint`), kept only where the impedance spectra stay within 1.1x their
misfit. Where the stage-wise machine is a little off every rotating edge overshoots by the
same 1-2 % (independent bench 204 at 100 rpm: model peaks 0.01-0.05 V above the measured at
all 16 edges, 1.40 % against the classical BVR model's 0.67 %; joint: 0.30 %). The joint
fit's intervals are widened by each quantity's shift between the two fits
(:func:`vfmodel.greybox.lsq.widen_interval`): its own covariance is confident about a split
between shared and per-speed values that a network unlike the machine leaves open (session
23: coverage 76/92 -> 92/92). Off by default: kept on 5 of 17 independent benches, it helped
on three (12 benches: mean 1.05 -> 0.98 %, BVR 70/72 -> 71/72) and was neutral on the fresh
ones (210-214: 1.15 -> 1.16 %); on the test bench of ``tests/test_reproduce.py`` (periodic
records) it raised the initial-state correction the model needs from 0.34 to 1.3 % of the
peak, so the exported netlist's periodic response (``vfmodel predict``) moved from 1.2 to
2.1 % off the measured peak while the corrected one improved 0.83 -> 0.79 %."""


EFFECT_LOCATIONS: dict[str, str] = {
    "winding_skin_effect": "winding",
    "insulation_dielectric_loss": "insulation",
    "frame_skin_effect": "frame",
    "shaft_skin_effect": "shaft",
    "ball_skin_effect": "bearing.balls",
    "lubricant_dielectric_loss": "bearing.lubricant",
    "lubricant_two_layer": "bearing.lubricant",
    "hertzian_edge_capacitance": "bearing.contact",
    "metallic_contact": "bearing.contact",
    "fixture_inductance": "fixture",
    "endwinding_capacitance": "winding.terminals",
}
"""The one place of the grey-box network where each effect applies (the ``location`` of a
detective finding; the network switches an effect everywhere it applies at once)."""


def check_effects(effects: object, name: str = "effects") -> frozenset[str]:
    """Frozen set of effect names; InputError naming ``name`` for an unknown one."""
    if isinstance(effects, str):
        effects = [effects]
    try:
        items = list(effects)  # type: ignore[call-overload]
    except TypeError:
        from vfmodel.errors import InputError

        raise InputError(f"{name}: expected an iterable of effect names, got "
                         f"{type(effects).__name__}") from None
    for e in items:
        check_choice(name, e, Effect)
    return frozenset(items)
