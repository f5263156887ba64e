"""The end-winding phase-to-phase capacitance (effect ``endwinding_capacitance``, issue 14
work): beyond the paper's network, never in the detective's start, a candidate; three
capacitors ``winding.C_pp`` between the terminals.

Reference (measured 2026-11-24, loaded machine, ``/tmp`` experiment recorded in
``docs/notes.md``): the six noise-free spectra of ``make_testbench`` seed 0 (truth with
15 pF between terminals) were fitted by the 4-section grey-box to 13.9 noise variances per
residual without the effect and 0.45 with it."""

from __future__ import annotations

import numpy as np

from vfmodel.greybox.assembly import TOPOLOGY_PORTS, build_network, default_params
from vfmodel.greybox.effects import ALL_EFFECTS, EFFECT_LOCATIONS, PAPER_EFFECTS
from vfmodel.greybox.identify import machine_names
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.priors import parameter_priors

EW = "endwinding_capacitance"


def test_vocabulary_and_structure() -> None:
    assert EW in ALL_EFFECTS and EW not in PAPER_EFFECTS
    assert EFFECT_LOCATIONS[EW] == "winding.terminals"
    p = default_params().with_values({"winding.C_pp": 15e-12})
    with_e = build_network(p, PAPER_EFFECTS | {EW})
    without = build_network(p, PAPER_EFFECTS)
    caps = {e.name: (e.nodes, e.value) for e in with_e.elements if e.name.startswith(
        "winding.C_") and e.name[-2:] in ("UV", "VW", "WU")}
    assert caps == {"winding.C_UV": (("U", "V"), 15e-12), "winding.C_VW": (("V", "W"), 15e-12),
                    "winding.C_WU": (("W", "U"), 15e-12)}
    assert len(with_e.elements) == len(without.elements) + 3
    assert "winding.C_pp" in machine_names(p, NetSpec(PAPER_EFFECTS | {EW}, 3, 2))
    assert "winding.C_pp" not in machine_names(p, NetSpec(PAPER_EFFECTS, 3, 2))
    pr = parameter_priors()["winding.C_pp"]
    assert pr.lower < 15e-12 < pr.upper


def test_seen_in_the_dm_spectra() -> None:
    """15 pF between the terminals moves the DM spectra above 1 MHz by far more than the
    0.5 % noise (sigma 0.0035 of ln Z)."""
    p = default_params().with_values({"winding.C_pp": 15e-12})
    f = np.logspace(3, 7, 41)
    pairs = [TOPOLOGY_PORTS[t] for t in ("U-V", "U-Frame")]
    za = build_network(p, PAPER_EFFECTS | {EW}).mna.response(f, pairs, pairs)
    zb = build_network(p, PAPER_EFFECTS).mna.response(f, pairs, pairs)
    d = np.abs(np.log(za[:, 0, 0] / zb[:, 0, 0]))
    assert float(d[f > 1e6].max()) > 10 * 0.0035
    assert float(d[f < 1e4].max()) < 0.0035       # below the resonances: no change
