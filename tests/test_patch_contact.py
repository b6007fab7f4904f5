"""The distributed (patch) contact of tread1dof (models/patch.py, docs/patch_contact.md).

Oracles: complex-step derivatives (Jacobian, df/dV); the brush model's closed forms
(parabolic and uniform pressure) in the limit of a stiff bristle; the distributed LuGre
model's closed form with a rigid tread; the series-spring brush integral (the cornering
stiffness of the defaults); the brush model's force build-up after a step in slip angle.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import quad
from polywear.models import get_model, model_for
from polywear.models.patch import brush_force, load_shares, steady_lateral_force
from polywear.params import ParameterError, Params

from .cli_runner import run_main

PATCH = {"friction.contact": "patch"}
BRUSH_LIMIT = {
    # a stiff bristle (sigma0 q >> k/L), Coulomb friction, no viscous terms, a light element:
    # the LuGre patch becomes the brush model of stiffness k/L per length
    "friction.contact": "patch",
    "friction.sigma0_per_m": 4.0e6,
    "friction.mu_static": 0.8,
    "friction.mu_coulomb": 0.8,
    "friction.sigma1_s_per_m": 0.0,
    "friction.sigma2_s_per_m": 0.0,
    "tread.mass_kg": 1.0e-4,
    "tread.lateral_damping_ns_per_m": 1.0,
}
SLIPS_DEG = (0.01, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0)
V = 30.0


def _force(params: Params, deg: float, speed: float = V) -> float:
    model = model_for(params)
    p = model.pack(params.with_updates({"operating.toe_deg": deg}))
    u = model.equilibrium(speed, p)
    return float(model.diagnostics(u, speed, p)[model.aux_names.index("friction_force")])


def test_point_contact_is_the_papers_model_itself():
    """friction.contact = point (the default) hands every analysis get_model(model): bit for bit."""
    assert model_for(Params()) is get_model("tread1dof")
    assert model_for(Params().with_updates({"model": "axle4dof"})) is get_model("axle4dof")


def test_patch_on_axle4dof_is_its_own_model():
    """axle4dof with the patch (docs/patch_contact.md section 6; tests/test_axle4dof_patch.py)."""
    assert model_for(Params().with_updates({"model": "axle4dof", **PATCH})).name == "axle4dof+patch"


@pytest.mark.parametrize("value", [1, 401, 2.5])
def test_patch_elements_bounds(value):
    with pytest.raises(ParameterError, match="friction.patch_elements"):
        Params().with_updates({"friction.patch_elements": value})


@pytest.mark.parametrize("pressure", ["parabolic", "uniform"])
def test_load_shares_integrate_the_pressure(pressure):
    shares = load_shares(pressure, 7)
    assert shares.sum() == pytest.approx(1.0, abs=1e-15)
    q = (lambda x: 0.75 * (1 - x * x)) if pressure == "parabolic" else (lambda x: 0.5)
    edges = np.linspace(-1, 1, 8)
    assert shares == pytest.approx([quad(q, a, b)[0] for a, b in zip(edges[:-1], edges[1:])], rel=1e-12)


@pytest.mark.parametrize("pressure", ["parabolic", "uniform"])
def test_jacobian_and_speed_derivative_against_complex_step(pressure):
    params = Params().with_updates({**PATCH, "friction.patch_elements": 6, "friction.patch_pressure": pressure})
    model = model_for(params)
    p = model.pack(params)
    rng = np.random.default_rng(1)
    u = model.equilibrium(V, p) * (1.0 + 0.3 * rng.standard_normal(model.n))  # off the steady state too
    h = 1e-30
    J = model.jacobian(u, V, p)
    Jc = np.column_stack([model.f(u + 1j * h * np.eye(model.n)[i], V, p).imag / h for i in range(model.n)])
    assert np.abs(J - Jc).max() <= 1e-13 * np.abs(J).max()
    fv = model.df_dspeed(u, V, p)
    assert fv == pytest.approx(model.f(u.astype(complex), V + 1j * h, p).imag / h, rel=1e-12, abs=1e-12)
    f, Jf, fvf = np.empty(model.n), np.empty((model.n, model.n)), np.empty(model.n)
    model.kernels.rhs_jac_dfdv(u, V, p, f, Jf, fvf)
    assert np.array_equal(f, model.f(u, V, p)) and np.array_equal(Jf, J) and np.array_equal(fvf, fv)


@pytest.mark.parametrize("toe, kmh", [(0.02, 110.0), (0.5, 110.0), (2.0, 30.0), (10.0, 250.0), (0.0, 110.0)])
def test_equilibrium_is_a_steady_state(toe, kmh):
    params = Params().with_updates({**PATCH, "operating.toe_deg": toe})
    model = model_for(params)
    p = model.pack(params)
    speed = kmh / 3.6
    u = model.equilibrium(speed, p)
    scale = np.abs(model.jacobian(u, speed, p)).max() * (np.abs(u).max() + 1e-9)
    assert np.abs(model.f(u, speed, p)).max() <= 1e-12 * scale
    if toe == 0.0:
        assert not u.any()


@pytest.mark.parametrize("pressure", ["parabolic", "uniform"])
def test_steady_force_converges_to_brush_theory_at_first_order(pressure):
    """Relative error e(M) against the closed form: about 1/M (first-order upwind), at every
    slip from 0.01 to 10 deg; 2.5-3.6 % at M = 40, a quarter of that at M = 160."""
    params = Params().with_updates({**BRUSH_LIMIT, "friction.patch_pressure": pressure})
    k, L = params.tread.lateral_stiffness_n_per_m, params.tire.contact_length_m
    errors = {}
    for M in (40, 160):
        P = params.with_updates({"friction.patch_elements": M})
        closed = [float(brush_force(math.radians(d), k / L, L / 2, 0.8, 4000.0, pressure)) for d in SLIPS_DEG]
        errors[M] = np.array([_force(P, d) / c - 1.0 for d, c in zip(SLIPS_DEG, closed)])
    assert np.abs(errors[40]).max() < 0.04
    assert np.abs(errors[160]).max() < 0.01
    order = math.log(np.median(errors[40] / errors[160])) / math.log(4.0)
    assert 0.85 < order < 1.2


def test_steady_force_converges_to_distributed_lugre_with_rigid_tread():
    """Rigid tread, uniform pressure: every element slides at V sin(alpha) and the bristle
    obeys V cos(alpha) dz/dx = v (1 - sigma0 z/G): closed form; the lumped average model
    (Canudas-de-Wit et al. 2003, kappa = 2/L: the same small-slip slope) agrees to 17 %."""
    params = Params().with_updates({**PATCH, "friction.patch_pressure": "uniform",
                                    "tread.lateral_stiffness_n_per_m": 1e9, "tread.mass_kg": 1e-3})
    f, L, N = params.friction, params.tire.contact_length_m, 4000.0
    for M, tol in ((40, 0.025), (160, 0.0065)):
        P = params.with_updates({"friction.patch_elements": M})
        for deg in SLIPS_DEG:
            a = math.radians(deg)
            v, vc = V * math.sin(a), V * math.cos(a)
            G = f.mu_coulomb + (f.mu_static - f.mu_coulomb) * math.exp(-((v / f.stribeck_velocity_m_per_s) ** 2))
            zeta = f.sigma0_per_m * v * L / (G * vc)
            z_mean = G / f.sigma0_per_m * (1 - (1 - math.exp(-zeta)) / zeta)
            z_rear = G / f.sigma0_per_m * (1 - math.exp(-zeta))
            exact = N * (f.sigma0_per_m * z_mean + f.sigma1_s_per_m * vc * z_rear / L + f.sigma2_s_per_m * v)
            lumped = N * (f.sigma0_per_m * v / (f.sigma0_per_m * v / G + 2.0 / L * vc) + f.sigma2_s_per_m * v)
            assert _force(P, deg) == pytest.approx(exact, rel=tol)
            assert lumped == pytest.approx(exact, rel=0.17)


def test_cornering_stiffness_of_the_defaults_is_the_series_brush():
    """The bristle (sigma0 q(x) per length) in series with the tread (k/L): C_alpha =
    integral of c_eff(x) x dx (31.5 kN/rad for the defaults; k a = 55 kN/rad with a rigid
    bristle), reached by a light element at low speed and many elements."""
    params = Params()
    k, L, N, s0 = params.tread.lateral_stiffness_n_per_m, params.tire.contact_length_m, 4000.0, 400.0
    a = L / 2

    def c_eff(x):
        q = 1.5 * N / L * (1 - ((x - a) / a) ** 2)
        return (k / L) * s0 * q / (k / L + s0 * q)

    expected = quad(lambda x: c_eff(x) * x, 0.0, L)[0]
    P = params.with_updates({"friction.patch_elements": 400, "tread.mass_kg": 1e-3, "operating.speed_kmh": 5.0})
    assert steady_lateral_force(P, [])["cornering_stiffness_n_per_rad"] == pytest.approx(expected, rel=0.01)


@pytest.mark.slow
def test_relaxation_after_a_step_in_slip_angle():
    """Brush model, linear range: after a step the force deficit is c (2a - s)^2/2 per unit
    slip (the elements in the patch keep their old deflection), so 63 % of the step is
    reached after s = 2a (1 - exp(-1/2)) = 43.3 mm of rolling for 2a = 0.11 m."""
    params = Params().with_updates({**BRUSH_LIMIT, "friction.sigma0_per_m": 4.0e4, "friction.patch_elements": 40})
    model = model_for(params)
    speed = 10.0
    p1, p2 = (model.pack(params.with_updates({"operating.toe_deg": d})) for d in (0.05, 0.1))
    u1 = model.equilibrium(speed, p1)
    F1, F2 = (model.diagnostics(model.equilibrium(speed, q), speed, q)[1] for q in (p1, p2))
    L = params.tire.contact_length_m
    t = np.linspace(0.0, 1.5 * L / speed, 601)
    dt = t[1] - t[0]
    states = [u1]
    for _ in t[1:]:  # trapezoidal rule (A-stable), Newton with the analytic Jacobian
        u0 = states[-1]
        f0 = model.f(u0, speed, p2)
        u = u0.copy()
        for _ in range(20):
            r = u - u0 - 0.5 * dt * (f0 + model.f(u, speed, p2))
            du = np.linalg.solve(np.eye(model.n) - 0.5 * dt * model.jacobian(u, speed, p2), -r)
            u += du
            if np.abs(du).max() <= 1e-13 * np.abs(u).max():
                break
        states.append(u)
    frac = (model.diagnostics(np.array(states), speed, p2)[:, 1] - F1) / (F2 - F1)
    i = int(np.argmax(frac >= 1 - math.exp(-1)))
    s63 = np.interp(1 - math.exp(-1), frac[i - 1 : i + 1], t[i - 1 : i + 1]) * speed * math.cos(math.radians(0.1))
    assert s63 == pytest.approx(L * (1 - math.exp(-0.5)), rel=0.04)


def test_patch_on_the_held_rim_does_not_self_excite():
    """Finding (docs/patch_contact.md): the elements leave the patch within 2a/V, so every
    disturbance is carried out; steady rolling is stable where the point contact vibrates."""
    for toe in (0.2, 0.5, 2.0):
        params = Params().with_updates({**PATCH, "operating.toe_deg": toe})
        model = model_for(params)
        p = model.pack(params)
        for kmh in (60.0, 110.0, 200.0):
            u = model.equilibrium(kmh / 3.6, p)
            assert np.linalg.eigvals(model.jacobian(u, kmh / 3.6, p)).real.max() < -1000.0
    point = get_model("tread1dof")
    p = point.pack(Params())
    u = point.equilibrium(110 / 3.6, p)
    assert np.linalg.eigvals(point.jacobian(u, 110 / 3.6, p)).real.max() > 0.0


def test_cli_friction_steady_json():
    code, stdout, stderr = run_main(["friction", "steady", "--contact", "patch", "--slip-deg", "0.05,0.5", "--json"])
    assert code == 0, stderr
    out = json.loads(stdout)
    assert set(out) == {"contact", "load_n", "cornering_stiffness_n_per_rad", "rows"}
    assert out["contact"] == "patch" and out["load_n"] == 4000.0
    assert [r["slip_deg"] for r in out["rows"]] == [0.05, 0.5]
    c_alpha = out["cornering_stiffness_n_per_rad"]
    assert out["rows"][0]["force_n"] == pytest.approx(c_alpha * math.tan(math.radians(0.05)), rel=0.01)
    point = json.loads(run_main(["friction", "steady", "--slip-deg", "0.05", "--json"])[1])
    assert point["contact"] == "point" and point["rows"][0]["force_n"] > 100 * out["rows"][0]["force_n"]
