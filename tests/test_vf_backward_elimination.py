"""Backward elimination of the automatic order: removing a representative by downdating
the least-squares factorisation (``_vf_core.drop_representative``) against a new
factorisation of the remaining poles (``removal_state`` / ``removal_costs``)."""

from __future__ import annotations

import numpy as np
import pytest

from vfmodel.fitting import _vf_core as core


def _problem(m_w: int, dc: bool) -> core.Problem:
    """Noisy samples of a random stable 2x2 response on 60 scaled frequencies, common
    (``m_w`` = 1) or per-response weights, with or without the 0 Hz constraint."""
    rng = np.random.default_rng(7 + m_w + 2 * dc)
    s = 1j * np.concatenate([[0.0] if dc else [], np.geomspace(1e-3, 1.0, 60)])
    poles = np.array([-0.02 + 0.3j, -0.01 + 0.05j, -0.2])
    res = rng.standard_normal((3, 4)) + 1j * rng.standard_normal((3, 4))
    res[2] = res[2].real
    h = sum(res[k][None, :] / (s[:, None] - poles[k])
            + (np.conj(res[k][None, :]) / (s[:, None] - np.conj(poles[k])) if poles[k].imag
               else 0.0) for k in range(3)) + 0.3
    h = h + 1e-3 * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    if dc:
        h[0] = h[0].real
    w = rng.uniform(0.5, 2.0, (s.size, m_w))
    return core.Problem(s, h, w, True, False, 0 if dc else None)


@pytest.mark.parametrize(("m_w", "dc"), [(1, False), (1, True), (4, False)])
def test_downdated_costs_equal_a_new_factorisation(m_w: int, dc: bool) -> None:
    prob = _problem(m_w, dc)
    reps = core.starting_poles(9, 1e-3, 1.0, "log")  # one real pole, four pairs
    x, s_mat = core.removal_state(prob, reps)
    for j in (0, 2, reps.size - 1):  # the real pole, a middle pair, the last pair
        got = core.drop_representative(x, s_mat, reps, j)
        assert got is not None
        x2, s2, rest, cost = got
        want_x, want_s = core.removal_state(prob, rest)
        want = core.removal_costs(prob, rest)
        # exact identities (Schur complement of the inverse Gram matrix): rounding only
        np.testing.assert_allclose(cost, want, rtol=1e-6, atol=1e-12 * float(np.max(want)))
        np.testing.assert_allclose(x2, want_x, rtol=1e-6, atol=1e-9 * float(np.max(np.abs(want_x))))
        np.testing.assert_allclose(s2, want_s, rtol=1e-6, atol=1e-9 * float(np.max(np.abs(want_s))))
