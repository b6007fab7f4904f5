"""The window's integration tolerance (wear.windows._RTOL) against a 1000x tighter run:
the coherent writes, the mean wear and the vibration's order of the same window."""

import numpy as np
import pytest

import polywear.wear.windows as windows
from polywear.models import model_for
from polywear.models.profile import coupled_model, profile_vector
from polywear.params import Params
from polywear.wear.evolution import initial_roughness


@pytest.mark.parametrize("v_kmh, bound", [(80.0, 5e-3), (110.0, 1e-3)])  # measured 2.1e-3, 2.0e-4
def test_window_writes_match_a_tight_integration(monkeypatch, v_kmh, bound):
    params = Params()
    base = model_for(params)
    V = v_kmh / 3.6
    W = initial_roughness(params) * 30.0
    u0 = coupled_model(base).equilibrium(V, profile_vector(base, params, V))
    u0[base.index("x")] += 1e-5
    assert windows._RTOL <= 1e-5
    window = windows.window_wear(params, V, W, u0, 1.0, 16, base)
    monkeypatch.setattr(windows, "_RTOL", 1e-8)
    tight = windows.window_wear(params, V, W, u0, 1.0, 16, base)
    largest = np.max(np.abs(tight.coherent))
    assert np.max(np.abs(window.coherent - tight.coherent)) < bound * largest
    assert window.mean_per_rev == pytest.approx(tight.mean_per_rev, rel=1e-4)
    assert window.order == pytest.approx(tight.order, abs=1e-4)
    assert not window.locked and not tight.locked
