#!/usr/bin/env python
"""Write the virtual test bench of a 40-kW-class PMSM (CONTRACT section 2 dataset layout).

    .venv/bin/python scripts/make_testbench.py --out data/pmsm40kw --seed 0

Impedance spectra of the six topologies (1 kHz - 10 MHz, log spaced, relative complex
noise ``--z-noise``) at standstill, and recordings ``rpm0000 ... rpm0500`` of the periodic
steady state of the truth network (benches.truth) fed by a two-level SiC inverter
through a cable (vfmodel.greybox.drive), with probe bandwidth, white noise and EMI.
``truth.json`` holds the truth parameters and the noise-free calibration numbers (for
tests; the pipeline does not read it). Deterministic for a given seed and arguments.

Unseen benches: ``--seed N --perturb 0.15`` (log-normal perturbation of every truth value)
and ``--variant`` (effect set of the truth network, see BENCH_VARIANTS).

``--extra-measurements`` adds the further measurements of CONTRACT section 2a
(benches/drive_extra.py): the Shaft-Frame impedance at standstill and at each rotating
speed, and the recording channels u_B_DE and i_CM, with noise from a random stream of
their own; without the flag the bench is unchanged byte for byte.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the benches package

from benches.drive_extra import extra_steady_state, shaft_frame_impedance
from benches.noise import add_noise, make_emi, snr_db
from benches.truth import (
    BENCH_VARIANTS,
    build_truth_network,
    lubricant_at_speed,
    truth_detail,
    truth_params,
)
from vfmodel.core.atomic import atomic_directory
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_spectrum import csv_text
from vfmodel.greybox.assembly import TOPOLOGY_PORTS
from vfmodel.greybox.bearing import divider_capacitances
from vfmodel.greybox.drive import (
    CableSpec,
    InverterSpec,
    ScopeSpec,
    drive_circuit,
    steady_state,
)
from vfmodel.signals.filters import brickwall_filter


def _args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="data/pmsm40kw", help="output dataset directory")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--variant", default="paper", choices=sorted(BENCH_VARIANTS))
    ap.add_argument("--perturb", type=float, default=0.0,
                    help="log-normal sigma of the truth-parameter perturbation (0 = nominal)")
    ap.add_argument("--speeds", default="0,100,200,300,400,500", help="rpm, comma separated")
    ap.add_argument("--periods", type=int, default=8, help="PWM periods per record")
    ap.add_argument("--fs", type=float, default=100e6, help="sample rate, Hz")
    ap.add_argument("--n-freq", type=int, default=401, help="impedance points")
    ap.add_argument("--z-noise", type=float, default=0.005, help="relative impedance noise")
    ap.add_argument("--name", default=None)
    ap.add_argument("--extra-measurements", action="store_true",
                    help="also write Shaft-Frame spectra and the u_B_DE, i_CM channels")
    return ap.parse_args(argv)




def make_bench(out: Path, seed: int = 0, variant: str = "paper", perturb: float = 0.0,
               speeds: tuple[float, ...] = (0, 100, 200, 300, 400, 500), periods: int = 8,
               fs: float = 100e6, n_freq: int = 401, z_noise: float = 0.005,
               name: str | None = None, n_coils: int = 4,
               n_rungs: int = 6, extra: bool = False) -> dict[str, object]:
    """Write the dataset to ``out`` (replaced atomically); returns the calibration summary.

    ``extra``: also the further measurements of CONTRACT section 2a (module docstring)."""
    effects = BENCH_VARIANTS[variant]
    ss = np.random.SeedSequence(seed)
    r_truth, r_detail, r_imp, r_noise = (np.random.default_rng(s) for s in ss.spawn(4))
    tp = truth_params(r_truth, perturb)
    det = truth_detail(r_detail, n_coils=n_coils, n_rungs=n_rungs)
    inv, cable = InverterSpec(), CableSpec()
    scope = ScopeSpec(fs_hz=fs, n_periods=periods)
    r_extra = np.random.default_rng(np.random.SeedSequence([seed, 78]))

    with atomic_directory(out) as tmp:
        (tmp / "impedance").mkdir()
        (tmp / "recordings").mkdir()
        # ---- impedance spectra at standstill
        p0, st0 = lubricant_at_speed(tp, 0.0)
        net0 = build_truth_network(p0, det, effects, st0)
        f = np.logspace(3, 7, n_freq)
        pairs = [TOPOLOGY_PORTS[t] for t in TOPOLOGY_PORTS]
        zz = net0.mna.response(f, pairs, pairs)
        fix = 2j * np.pi * f * tp["fixture.L"] if "fixture_inductance" in effects else 0.0
        imp_summary = {}
        for i, topo in enumerate(TOPOLOGY_PORTS):
            z = zz[:, i, i] + fix
            noise = z_noise * np.abs(z) * (r_imp.standard_normal(f.size)
                                           + 1j * r_imp.standard_normal(f.size)) / np.sqrt(2)
            (tmp / "impedance" / f"{topo}.csv").write_text(
                csv_text(FrequencyData(f, z + noise, kind="Z")))
            imp_summary[topo] = {"z_1khz_ohm": abs(z[0]),
                                 "c_1khz_f": float(-1 / (2 * np.pi * f[0] * z[0].imag))
                                 if "Frame" in topo else None,
                                 "z_min_ohm": float(np.abs(z).min()),
                                 "f_at_z_min_hz": float(f[np.argmin(np.abs(z))])}
        at_speed: list[str] = []
        # ---- recordings: noise-free steady states first (bearing noise set at 0 rpm)
        clean = {}
        clean_extra = {}
        for rpm in speeds:
            p, st = lubricant_at_speed(tp, rpm)
            net = build_truth_network(p, det, effects, st)
            mna = drive_circuit(net, cable).mna
            clean[rpm] = steady_state(net, inv, cable, scope, rpm, mna=mna)
            if extra:
                clean_extra[rpm] = extra_steady_state(net, inv, cable, scope, rpm, mna=mna)
        if extra:
            for rpm in (0.0, *(x for x in speeds if x > 0)):
                p, st = lubricant_at_speed(tp, rpm)
                z = shaft_frame_impedance(build_truth_network(p, det, effects, st), f) + fix
                z = z + z_noise * np.abs(z) * (r_extra.standard_normal(f.size) + 1j
                                               * r_extra.standard_normal(f.size)) / np.sqrt(2)
                fname = "Shaft-Frame.csv" if rpm == 0 else f"Shaft-Frame_{round(rpm):04d}rpm.csv"
                (tmp / "impedance" / fname).write_text(csv_text(FrequencyData(f, z, kind="Z")))
                if rpm > 0:
                    at_speed += ["", "[[impedance_at_speed]]", 'topology = "Shaft-Frame"',
                                 f"speed_rpm = {float(rpm)}", f'file = "impedance/{fname}"']
        ref = clean[min(speeds)][3]
        bearing_rms = float(np.std(ref)) / 10 ** (scope.snr_bearing_db_standstill / 20)
        recs = {}
        toml = [f'name = "{name or "pmsm40kw-bench-" + variant + "-seed" + str(seed)}"',
                'description = "virtual test bench: 40-kW-class PMSM truth network, two-level '
                'SiC inverter (8 kHz, 51/26 ns), cable ringing, 25 MHz probes, EMI; '
                'made by scripts/make_testbench.py"',
                "temperature_c = 80.0", "", "[impedance]"]
        toml += [f'"{t}" = "impedance/{t}.csv"' for t in TOPOLOGY_PORTS]
        if extra:
            toml.append('"Shaft-Frame" = "impedance/Shaft-Frame.csv"')
            # i_CM noise: 30 dB below the standstill record (a current probe on the cable)
            i_rms = float(np.std(clean_extra[min(speeds)][1])) / 10 ** (30 / 20)
        for rpm in speeds:
            y = clean[rpm]
            rms = np.r_[np.std(y[:3], axis=1) / 10 ** (scope.snr_terminal_db / 20), bearing_rms]
            emi = make_emi(r_noise, inv, scope, rpm)
            noisy = add_noise(y, rms, emi, scope.emi_fraction, r_noise)
            fname = f"rpm{round(rpm):04d}.npz"
            more = {}
            if extra:
                # same scope: the DE probe has the NDE probe's noise level and shares the EMI
                ye = add_noise(clean_extra[rpm], np.array([bearing_rms, i_rms]), emi,
                               scope.emi_fraction, r_extra)
                more = {"u_B_DE": ye[0].astype(np.float32), "i_CM": ye[1].astype(np.float32)}
            np.savez_compressed(tmp / "recordings" / fname,
                                u_U=noisy[0].astype(np.float32), u_V=noisy[1].astype(np.float32),
                                u_W=noisy[2].astype(np.float32), u_B=noisy[3].astype(np.float32),
                                **more, fs=np.float64(fs))
            snr = snr_db(y, noisy)
            recs[str(round(rpm))] = {
                "peak_terminal_v": float(np.abs(y[:3]).max()),
                "peak_u_b_clean_v": float(np.abs(brickwall_filter(y[3], fs, 10e6)).max()),
                "peak_u_b_clean_fullband_v": float(np.abs(y[3]).max()),
                "peak_u_cm_clean_v": float(np.abs(y[:3].mean(axis=0)).max()),
                "snr_terminal_db": float(np.mean(snr[:3])),
                "snr_u_b_db": float(snr[3]),
                "lubricant": {k: p for k, p in lubricant_at_speed(tp, rpm)[0].as_dict().items()
                              if k.startswith("lubricant.")},
            }
            toml += ["", "[[recording]]", f"speed_rpm = {float(rpm)}",
                     f'file = "recordings/{fname}"']
            if extra:
                recs[str(round(rpm))].update({  # type: ignore[attr-defined]
                    "peak_u_b_de_clean_v": float(np.abs(brickwall_filter(
                        clean_extra[rpm][0], fs, 10e6)).max()),
                    "rms_i_cm_clean_a": float(np.std(clean_extra[rpm][1]))})
        toml += at_speed
        (tmp / "dataset.toml").write_text("\n".join(toml) + "\n")
        summary = {
            "seed": seed, "variant": variant, "perturb": perturb,
            "effects": sorted(effects),
            "truth_params": tp.as_dict(),
            "truth_detail": det.to_json_dict(),
            "divider": divider_capacitances(tp, effects),
            "inverter": vars(inv), "cable": vars(cable),
            "scope": {**vars(scope), "emi_band_hz": list(scope.emi_band_hz)},
            "bearing_noise_rms_v": bearing_rms,
            "impedance": imp_summary, "recordings": recs,
            "snr_definition": "10 log10(var(clean) / mean(noise^2)) over the stored "
                              "full-band record; noise = white + EMI",
        }
        (tmp / "truth.json").write_text(json.dumps(summary, indent=1) + "\n")
    return summary


def main(argv: list[str] | None = None) -> int:
    a = _args(argv)
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    speeds = tuple(float(s) for s in a.speeds.split(","))
    s = make_bench(out, a.seed, a.variant, a.perturb, speeds, a.periods, a.fs, a.n_freq,
                   a.z_noise, a.name, extra=a.extra_measurements)
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    print(f"wrote {out} ({size / 1e6:.2f} MB)", file=sys.stderr)
    for rpm, r in s["recordings"].items():  # type: ignore[attr-defined]
        print(f"  {rpm:>4} rpm: terminal peak {r['peak_terminal_v']:.1f} V, u_B peak "
              f"{r['peak_u_b_clean_v']:.3f} V, SNR terminals {r['snr_terminal_db']:.1f} dB, "
              f"u_B {r['snr_u_b_db']:.2f} dB", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
