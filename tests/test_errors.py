"""One root exception: every error polywear raises on purpose is a ``PolywearError``, of one
of three kinds (parameter, input, numerical), and still the builtin it was before."""

from __future__ import annotations

import numpy as np
import pytest

import polywear as pw
from polywear.errors import InputError, NumericalError, PolywearError
from polywear.friction.data import FrictionDataError, read_steady_csv
from polywear.measured.calibration import CalibrationError, read_observations
from polywear.measured.run_file import MeasurementError, read_run
from polywear.measured.profile import ProfileError
from polywear.measured.tir import TirError, read_tir
from polywear.models import get_model
from polywear.params import ParameterError
from polywear.solvers.integrate import IntegrationError, integrate
from polywear.units import kmh_to_ms
from polywear.validation.auto07p import Auto07pError

# error -> (kind under PolywearError, the builtin that older except clauses name)
KINDS = {
    ParameterError: (ParameterError, ValueError),
    FrictionDataError: (InputError, ValueError),
    TirError: (InputError, ParameterError),
    MeasurementError: (InputError, ParameterError),
    CalibrationError: (InputError, ParameterError),
    ProfileError: (InputError, ValueError),
    IntegrationError: (NumericalError, RuntimeError),
    Auto07pError: (NumericalError, RuntimeError),
}


@pytest.mark.parametrize("error", list(KINDS), ids=lambda e: e.__name__)
def test_every_error_sits_under_the_root_and_keeps_its_builtin(error):
    kind, builtin = KINDS[error]
    assert issubclass(error, PolywearError) and issubclass(error, kind) and issubclass(error, builtin)


def test_the_three_kinds_are_distinct():
    assert not issubclass(NumericalError, ValueError) and not issubclass(InputError, RuntimeError)
    assert not issubclass(ParameterError, InputError) and not issubclass(InputError, ParameterError)
    assert pw.PolywearError is PolywearError


def test_a_bad_parameter_is_caught_as_polywear_error():
    with pytest.raises(PolywearError, match="operating.toe_deg") as info:
        pw.load_params().with_updates({"operating.toe_deg": 45.0})
    assert isinstance(info.value, ValueError)


def test_unreadable_inputs_are_input_errors(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("sliding_velocity_m_per_s,friction_coefficient\n0.1,abc\n")
    not_tir = tmp_path / "x.tir"
    not_tir.write_text("this is not a tyre property file\n")
    missing = tmp_path / "missing.toml"
    for read, path, error in ((read_steady_csv, bad, FrictionDataError), (read_tir, not_tir, TirError),
                              (read_run, bad, MeasurementError), (read_observations, missing, CalibrationError)):
        with pytest.raises(InputError) as info:
            read(path)
        assert type(info.value) is error and path.name in str(info.value)


def test_an_integrator_that_gives_up_is_a_numerical_error():
    model = get_model("tread1dof")
    with pytest.raises(NumericalError, match="max_steps") as info:
        integrate(model, np.full(model.n, 1e-4), kmh_to_ms(100.0), model.pack(pw.Params()), 1.0, max_steps=3)
    assert isinstance(info.value, IntegrationError) and isinstance(info.value, RuntimeError)
