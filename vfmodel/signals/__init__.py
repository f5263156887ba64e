"""FFT filter, spectral energy, edges, MIMO H1 estimator, LTI simulation of sampled inputs.

Modules (import from them directly; ``vfmodel.h1_estimate`` and ``vfmodel.simulate`` are
the contract names):

- :mod:`.filters`: ``brickwall_filter`` (the paper's FFT filter), ``lowpass_fir``,
  ``filter_blocks`` (streaming FIR counterpart for long records).
- :mod:`.spectral`: ``spectral_energy``, ``energy_fraction_above``, ``edge_times``,
  ``cutoff_frequency`` (paper eq. 2).
- :mod:`.h1`: ``h1_estimate`` (contract), ``h1_analysis`` -> ``H1Result``,
  ``h1_analysis_blocks`` (streaming), ``bvr`` (paper eq. 3).
- :mod:`.simulate`: ``simulate`` (zero state), ``simulate_blocks`` (streaming),
  ``simulate_periodic`` (periodic steady state), ``discrete_transfer``.
"""
