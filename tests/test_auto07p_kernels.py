"""The compiled kernels as AUTO-07p sees them on bifpy's callback path (no AUTO needed).

``axle4dof`` reaches AUTO only this way (``validation.auto07p.kernel_rhs`` and
``kernel_jacobian`` around ``MODEL.f``, ``MODEL.jacobian`` and ``MODEL.df_dspeed``, in
AUTO's scaled units). Checked here: the scaling, against the hand-written ``tread1dof``
equations that AUTO compiles natively; the Jacobian and speed column, against finite
differences of the callback right-hand side; the refusals of ``model_diagram``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from polywear.units import kmh_to_ms
from polywear.models.tread1dof import MODEL as TREAD
from polywear.params import ParameterError, Params, with_updates
from polywear.validation import auto07p as A

PERIOD_INDEX = 11  # AUTO's PAR index of the period (bifpy.auto.PERIOD_INDEX)
AXLE = A.AUTO_MODELS["axle4dof"]


@settings(max_examples=40, deadline=None)
@given(
    speed_kmh=st.floats(20.0, 300.0),
    offset=st.tuples(st.floats(-3.0, 3.0), st.floats(-0.6, 0.6), st.floats(-3.0, 3.0)),
)
def test_kernel_callbacks_equal_the_hand_written_tread1dof_equations(speed_kmh, offset):
    """Two routes to AUTO's FUNC and Jacobian for tread1dof: the kernels wrapped and
    scaled by the generic callbacks, and the equations written out for bifpy's tracer."""
    p = TREAD.pack(with_updates(Params(), {"tread.lateral_damping_ns_per_m": 40.0}))
    V = kmh_to_ms(speed_kmh)
    scaled = TREAD.equilibrium(V, p) / np.asarray(A.STATE_UNIT) + np.asarray(offset)
    icu = [A.SPEED_INDEX, PERIOD_INDEX]
    func, jacobian_for = A.AUTO_MODELS["tread1dof"].equations(p)
    kernel_func = A.kernel_rhs(TREAD, p, A.STATE_UNIT)
    np.testing.assert_allclose(kernel_func(scaled, [V]), func(scaled, [V]), rtol=1e-12, atol=1e-12)
    slide = V * np.sin(p[TREAD.param_names.index("toe")]) - scaled[1] * A.STATE_UNIT[1]
    if abs(slide) < 1e-9:  # not differentiable at v_r = 0
        return
    d_state, d_par = A.kernel_jacobian(TREAD, p, A.STATE_UNIT, icu)(scaled, [V])
    hand_state, hand_par = (np.array(m) for m in jacobian_for(icu)(scaled, [V]))
    np.testing.assert_allclose(d_state, hand_state, rtol=1e-12, atol=1e-12 * np.abs(hand_state).max())
    np.testing.assert_allclose(d_par, hand_par, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("speed_kmh", [60.0, 110.0, 158.0])
@pytest.mark.parametrize("icu", [[1, PERIOD_INDEX], [PERIOD_INDEX, 1]])
def test_axle4dof_callback_jacobian_matches_finite_differences(speed_kmh, icu):
    """At a state off the equilibrium (rates and angles of a typical cycle), central
    differences of the callback FUNC in AUTO's units against its analytic Jacobian."""
    model = AXLE.model
    p = model.pack(Params(model="axle4dof"))
    V = kmh_to_ms(speed_kmh)
    unit = np.asarray(AXLE.state_unit)
    #                    alpha  beta  gamma  x    alpha' beta' gamma' x'   z   (AUTO units)
    offset = np.array([0.02, -0.05, 3e-4, 0.2, 0.015, -0.04, 2e-4, 0.15, 0.05])
    scaled = model.equilibrium(V, p) / unit + offset
    func, jacobian_for = AXLE.equations(p)
    d_state, d_par = jacobian_for(icu)(scaled, np.array([V]))
    h = 1e-6
    for j in range(model.n):
        step = np.zeros(model.n)
        step[j] = h
        central = (func(scaled + step, [V]) - func(scaled - step, [V])) / (2 * h)
        np.testing.assert_allclose(d_state[:, j], central, rtol=1e-6, atol=1e-7 * np.abs(d_state).max())
    speed = icu.index(A.SPEED_INDEX)
    central = (func(scaled, [V + h]) - func(scaled, [V - h])) / (2 * h)
    np.testing.assert_allclose(d_par[:, speed], central, rtol=1e-6, atol=1e-9)
    assert np.all(d_par[:, 1 - speed] == 0.0)  # the period is AUTO's own unknown
    # AUTO's units: rates of angles [rad/s] and of x [m/s] are per ms of AUTO time
    np.testing.assert_allclose(func(scaled, [V]), model.f(unit * scaled, V, p) * 1e-3 / unit, rtol=1e-14)


def test_model_diagram_refuses_what_it_cannot_do():
    with pytest.raises(ParameterError, match="transpile=False"):
        A.model_diagram(Params(model="axle4dof"), settings=A.AutoSettings(transpile=True))
    with pytest.raises(ParameterError, match="tread1dof only"):
        A.tread1dof_diagram(Params(model="axle4dof"))
    with pytest.raises(ParameterError, match="speed range"):
        A.model_diagram(Params(model="axle4dof"), (100.0, 50.0))
    assert not AXLE.settings.transpile and A.AUTO_MODELS["tread1dof"].settings.transpile
