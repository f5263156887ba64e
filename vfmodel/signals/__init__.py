"""FFT filter, spectral energy, edges, MIMO H1 estimator, LTI simulation of sampled inputs."""
