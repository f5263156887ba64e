"""Netlists, batched MNA, network poles, SPICE export/import, synthesis, ngspice runner."""
