"""Random connected RLC networks for tests and benchmarks.

The generator builds a spanning tree of resistors and inductors (so every node has a DC
path to ground), adds extra R, L, C branches and ideal switches between random node pairs,
couples some inductor pairs (each inductor at most once, so the inductance matrix stays
positive definite) and drives the network from a voltage source behind a resistor. It never
closes a loop of inductors, closed switches and the source, so the DC operating point that
SPICE computes before an AC analysis exists.
"""

from __future__ import annotations

import numpy as np

from vfmodel.circuit.netlist import Circuit


def random_rlc_network(
    rng: np.random.Generator,
    n_nodes: int = 14,
    n_elements: int = 34,
    *,
    n_switches: int = 2,
    n_mutual: int = 2,
) -> Circuit:
    """A random network with ``n_nodes`` internal nodes and at least ``n_elements`` elements.

    Nodes are ``n1 ... n{n_nodes}`` and ``src``; the source is ``V1`` (AC 1) from ``src``
    to ground, in series with ``Rs``. Element names are hierarchical (``tree.3.R`` ...).
    """
    nodes = [f"n{k}" for k in range(1, n_nodes + 1)]
    parent: dict[str, str] = {}

    def find(n: str) -> str:
        while parent.setdefault(n, n) != n:
            n = parent[n]
        return n

    c = Circuit(title="random RLC network")
    c = c.add_vsource("V1", "src", "0", 1.0)
    c = c.add_resistor("Rs", "src", nodes[0], float(10 ** rng.uniform(0, 2)))
    parent[find("src")] = find("0")
    inductors: list[str] = []
    everyone = ["0", *nodes]
    for k in range(1, len(everyone)):
        a, b = everyone[k], everyone[int(rng.integers(0, k))]
        if rng.random() < 0.5:
            c = c.add_resistor(f"tree.{k}.R", a, b, float(10 ** rng.uniform(0, 4)))
        else:
            name = f"tree.{k}.L"
            c = c.add_inductor(name, a, b, float(10 ** rng.uniform(-7, -4)))
            inductors.append(name)
            parent[find(a)] = find(b)
    k = 0
    n_sw = 0
    while len(c) < n_elements - n_mutual:
        k += 1
        i, j = rng.choice(len(everyone), size=2, replace=False)
        a, b = everyone[int(i)], everyone[int(j)]
        u = rng.random()
        if n_sw < n_switches and u < 0.15:
            closed = bool(rng.random() < 0.5)
            if closed and find(a) == find(b):
                continue
            if closed:
                parent[find(a)] = find(b)
            c = c.add_switch(f"extra.{k}.S", a, b, closed)
            n_sw += 1
        elif u < 0.45:
            c = c.add_resistor(f"extra.{k}.R", a, b, float(10 ** rng.uniform(0, 4)))
        elif u < 0.75:
            c = c.add_capacitor(f"extra.{k}.C", a, b, float(10 ** rng.uniform(-11, -8)))
        else:
            if find(a) == find(b):
                continue
            parent[find(a)] = find(b)
            name = f"extra.{k}.L"
            c = c.add_inductor(name, a, b, float(10 ** rng.uniform(-7, -4)))
            inductors.append(name)
    order = rng.permutation(len(inductors))
    for m in range(min(n_mutual, len(inductors) // 2)):
        l1, l2 = inductors[int(order[2 * m])], inductors[int(order[2 * m + 1])]
        c = c.add_mutual(f"coupling.{m}.K", l1, l2, float(rng.uniform(0.05, 0.6)))
    return c
