"""The coupled model's rhs and diagnostics write the profile's load into the parameter
vector in place (no copy): bit for bit the copying path, and the vector is left unchanged."""

import numpy as np
import pytest
from numba import njit

from polywear.models import model_for
from polywear.models import profile as pr
from polywear.params import Params, with_updates
from polywear.wear.evolution import initial_roughness
from polywear.wear.windows import table_points


@njit
def _copying_rhs(u, V, p, out):
    n = u.size - 1
    q = pr._loaded(u, V, p)[0]
    pr._base_rhs(int(p[0].real), u[:n], V, q, out[:n])
    out[n] = V / p[2]


@njit
def _copying_aux(u, V, p, out):
    n = u.size - 1
    q = pr._loaded(u, V, p)[0]
    pr._base_aux(int(p[0].real), u[:n], V, q, out)


@pytest.mark.parametrize("model", ["tread1dof", "axle4dof"])
@pytest.mark.parametrize("roughness", [1.0, 3e4])  # 3e4: a 30 mm profile, the load clamps at 0 (tread1dof)
def test_in_place_load_matches_copy(model, roughness):
    params = with_updates(Params(), {"model": model})
    base = model_for(params)
    coupled = pr.coupled_model(base)
    V = 110.0 / 3.6
    W = initial_roughness(params) * roughness
    sinc = pr.patch_sinc(np.arange(1, W.size + 1), params.tire.contact_length_m, params.operating.rolling_radius_m)
    p = coupled.prepared(V, pr.profile_vector(base, params, V, sinc * W.real, -sinc * W.imag, table_points(W.size)))
    p0 = p.copy()
    u0 = coupled.equilibrium(V, p)
    rng = np.random.default_rng(3)
    scale = np.maximum(np.abs(u0), 1e-3)
    clamped = 0
    n_aux = len(base.aux_names)
    for _ in range(500):
        u = u0 + rng.normal(size=u0.size) * scale
        u[-1] = rng.uniform(0.0, 2.0 * np.pi)
        a, b = np.empty(u.size), np.empty(u.size)
        _copying_rhs(u, V, p, a)
        pr.rhs(u, V, p, b)
        c, d = np.empty(n_aux), np.empty(n_aux)
        _copying_aux(u, V, p, c)
        pr.aux(u, V, p, d)
        assert np.array_equal(a, b) and np.array_equal(c, d)
        clamped += pr._loaded(u, V, p)[1]
    assert np.array_equal(p, p0)
    if model == "tread1dof" and roughness > 1.0:
        assert clamped > 0  # the clamped branch was exercised
