"""Calibration: exact Jacobian, recovery of known parameters with honest intervals,
identifiability (the four-way scaling null direction), refusals and one-line errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from polywear.measured.calibration import (
    CalibrationError,
    CalibrationSettings,
    Observation,
    calibrate,
    predict,
    read_observations,
)
from polywear.params import Params, get_value, with_updates

from .cli_runner import run_main

KEYS = ["tread.lateral_damping_ns_per_m", "friction.stribeck_velocity_m_per_s"]
TOE = (("operating.toe_deg", 0.3),)


def _observations(sigmas=(1.0, 2.0, 0.5, 1.0, 0.01)) -> list[Observation]:
    quantities = [("first_hopf_kmh", ()), ("second_hopf_kmh", ()), ("hopf_frequency_hz", ()),
                  ("first_hopf_kmh", TOE), ("friction_mu", ())]
    return [Observation(q, 0.0, s, set=c, at_sliding_speed_m_per_s=0.3 if q == "friction_mu" else None)
            for (q, c), s in zip(quantities, sigmas)]


def _with_values(obs, values):
    return [Observation(o.quantity, float(v), o.sigma, o.at_speed_kmh, o.at_sliding_speed_m_per_s, o.set)
            for o, v in zip(obs, values)]


def test_jacobian_matches_central_differences():
    obs = _observations() + [Observation("second_hopf_frequency_hz", 0.0, 1.0),
                             Observation("friction_mu", 0.0, 0.01, at_sliding_speed_m_per_s=0.1)]
    keys = [*KEYS, "friction.mu_static", "friction.stribeck_exponent", "tread.mass_kg", "friction.sigma2_s_per_m"]
    params = Params()
    _, jac = predict(params, obs, keys)
    for j, key in enumerate(keys):
        x = get_value(params, key)
        h = 1e-5 * x
        hi, _ = predict(with_updates(params, {key: x + h}), obs, keys)
        lo, _ = predict(with_updates(params, {key: x - h}), obs, keys)
        fd = (hi - lo) / (2 * h)
        assert jac[:, j] == pytest.approx(fd, rel=1e-5, abs=1e-9 * np.max(np.abs(fd))), key


@pytest.mark.slow
def test_cycle_quantities_and_their_jacobian():
    """Amplitude, frequency and polygon order of the stable cycle at 110 km/h: values from the
    continuation, derivatives (collocation system differentiated) against central differences
    of whole new diagrams."""
    obs = [Observation(q, 0.0, 1.0, at_speed_kmh=110.0) for q in ("amplitude_x_mm", "cycle_frequency_hz", "frequency_order")]
    keys = ["tread.lateral_damping_ns_per_m", "operating.rolling_radius_m"]
    params = Params()
    values, jac = predict(params, obs, keys)
    assert values[0] == pytest.approx(0.27, abs=0.005)  # the defaults' stable cycle at 110 km/h
    assert values[2] == pytest.approx(values[1] * 2 * math.pi * 0.30 / (110 / 3.6), rel=1e-12)
    # R_e does not enter tread1dof: only the polygon order moves, as n / R_e
    assert jac[:, 1] == pytest.approx([0.0, 0.0, values[2] / 0.30], rel=1e-12)
    h = 1e-4 * 80.0
    hi, _ = predict(with_updates(params, {keys[0]: 80.0 + h}), obs, keys)
    lo, _ = predict(with_updates(params, {keys[0]: 80.0 - h}), obs, keys)
    assert jac[:, 0] == pytest.approx((hi - lo) / (2 * h), rel=1e-4)


@pytest.mark.slow
def test_recovery_within_stated_intervals_in_50_trials():
    """Truth drawn around the defaults, observations = model(truth) + noise of the stated sigma,
    fit from the defaults: each 95 % interval must hold the truth in >= 90 % of 50 trials."""
    base = [o for o in _observations() if not o.set]  # one test condition: one eigen-analysis per evaluation
    rng = np.random.default_rng(20261201)
    hits = np.zeros(len(KEYS), int)
    evaluations = []
    for _ in range(50):
        truth = with_updates(Params(), {k: get_value(Params(), k) * math.exp(rng.normal(0.0, 0.1)) for k in KEYS})
        exact, _ = predict(truth, base, KEYS, settings=CalibrationSettings(n_speeds=60))
        noisy = exact + rng.normal(size=len(base)) * np.array([o.sigma for o in base])
        result = calibrate(Params(), _with_values(base, noisy), KEYS, settings=CalibrationSettings(n_speeds=60),
                           profile=False)
        evaluations.append(result.identifiability["evaluations"])
        for j, entry in enumerate(result.parameters):
            assert entry["identifiable"]
            hits[j] += entry["ci_low"] <= get_value(truth, entry["key"]) <= entry["ci_high"]
    assert np.all(hits >= 45), (hits, evaluations)


def test_profile_interval_is_exact_for_a_linear_observation():
    """mu_ss(v) is linear in mu_s: chi^2 is an exact parabola, so the profile interval is
    mu_s_hat +- 1.96 sigma / (d mu_ss / d mu_s), with d mu_ss / d mu_s = exp(-(v/v_s)^delta)."""
    f = Params().friction
    obs = [Observation("friction_mu", 0.7, 0.02, at_sliding_speed_m_per_s=0.2),
           Observation("friction_mu", 0.66, 0.02, at_sliding_speed_m_per_s=0.25)]
    result = calibrate(Params(), obs, ["friction.mu_static"])
    entry = result.parameters[0]
    v = np.array([0.2, 0.25])
    e = np.exp(-((v / f.stribeck_velocity_m_per_s) ** f.stribeck_exponent))
    # weighted least squares for y = mu_c + (mu_s - mu_c) e + sigma2 v, linear in mu_s
    y = np.array([0.7, 0.66]) - f.mu_coulomb * (1 - e) - f.sigma2_s_per_m * v
    w = e / 0.02
    mu_hat = float(w @ (y / 0.02) / (w @ w))
    sd = 1.0 / math.sqrt(float(w @ w))
    assert entry["value"] == pytest.approx(mu_hat, rel=1e-9)
    assert entry["profile_ci"] == pytest.approx([mu_hat - 1.959964 * sd, mu_hat + 1.959964 * sd], rel=1e-4)


def test_four_way_scaling_is_flagged_not_fitted():
    """Scaling m, k, c and N by one factor leaves Hopf speeds and frequencies unchanged:
    the combination (1, 1, 1, 1)/2 in ln p must be reported undetermined and no value given."""
    keys = ["tread.mass_kg", "tread.lateral_stiffness_n_per_m", "tread.lateral_damping_ns_per_m",
            "operating.vertical_load_n"]
    obs = _observations()[:4] + [Observation("second_hopf_kmh", 0.0, 2.0, set=(("operating.toe_deg", 0.7),))]
    exact, _ = predict(Params(), obs, keys)
    result = calibrate(Params(), _with_values(obs, exact * 1.01), keys, profile=False)
    vectors = [np.array(list(c["vector"].values())) for c in result.identifiability["undetermined"]]
    assert any(np.allclose(np.abs(v), 0.5, atol=1e-6) for v in vectors)
    assert all(p["value"] is None and not p["identifiable"] for p in result.parameters)
    assert "+0.50 ln(tread.mass_kg)" in result.parameters[0]["reason"]
    assert result.identifiability["refused"] == keys


def test_too_few_observations_and_bad_requests():
    obs = _observations()[:1]
    with pytest.raises(CalibrationError, match="1 observation cannot determine 2 parameters"):
        calibrate(Params(), obs, KEYS)
    with pytest.raises(CalibrationError, match="fixes operating.toe_deg, which is varied"):
        calibrate(Params(), _observations(), ["operating.toe_deg"])
    with pytest.raises(CalibrationError, match="not a float parameter key"):
        calibrate(Params(), _observations(), ["axle.reference"])


OBS_TOML = """\
[[observation]]
quantity = "first_hopf_kmh"
value = 60.2
sigma = 1.0

[[observation]]
quantity = "hopf_frequency_hz"
value = 126.0
sigma = 0.5

[[observation]]
quantity = "first_hopf_kmh"
value = 95.0
sigma = 1.5
set = { "operating.toe_deg" = 0.3 }
"""


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (OBS_TOML.replace("first_hopf_kmh", "amplitude_xx", 1), "quantity = 'amplitude_xx' is not one calibrate fits"),
        (OBS_TOML.replace("sigma = 1.0", "sigma = 0.0"), "sigma = 0.0: must be positive"),
        (OBS_TOML.replace('"operating.toe_deg" = 0.3', '"operating.toe_deg" = 40.0'), "set: operating.toe_deg"),
        (OBS_TOML.replace("sigma = 1.0", "sigma = 1.0\nunit = 3"), "unknown field 'unit'"),
        ('[[observation]]\nquantity = "friction_mu"\nvalue = 0.6\nsigma = 0.1\n', "at_sliding_speed_m_per_s missing"),
        ("x = 1\n", "no [[observation]] tables"),
    ],
)
def test_observation_file_errors_are_one_line(tmp_path, text, message):
    path = tmp_path / "obs.toml"
    path.write_text(text)
    with pytest.raises(CalibrationError, match=message.replace("[", r"\[").replace("(", r"\(")):
        read_observations(path, Params())
    code, out, err = run_main(["calibrate", "--observed", str(path), "--vary", KEYS[0], "--json"])
    assert code == 2 and out == "" and err.count("\n") == 1


def test_cli_json_shape(tmp_path):
    path = tmp_path / "obs.toml"
    path.write_text(OBS_TOML)
    fitted = tmp_path / "fitted.toml"
    code, out, err = run_main(["calibrate", "--observed", str(path), "--vary", KEYS[0], "--vary", KEYS[1],
                               "--json", "-q", "--fitted", str(fitted)])
    assert code == 0, err
    payload = json.loads(out)
    assert set(payload) == {"parameters", "residuals", "identifiability"}
    for entry in payload["parameters"]:
        assert {"key", "value", "ci_low", "ci_high", "identifiable"} <= set(entry)
        assert entry["identifiable"] and entry["ci_low"] < entry["value"] < entry["ci_high"]
    assert payload["identifiability"]["dof"] == 1
    assert len(payload["residuals"]) == 3
    code, out, _ = run_main(["params", "show", "-c", str(fitted), "--json"])
    assert json.loads(out)["tread"]["lateral_damping_ns_per_m"] == pytest.approx(payload["parameters"][0]["value"])
    code, _, err = run_main(["calibrate", "--observed", str(path), "--vary", KEYS[0], "--vary", KEYS[1],
                             "--vary", "tread.mass_kg", "--vary", "friction.mu_static"])
    assert code == 2 and "3 observations cannot determine 4 parameters" in err


@pytest.mark.parametrize(("old", "new", "message"), [
    ("value = 60.2", "value = -60.0", "first_hopf_kmh value = -60.0: a speed must be in (0, 1000] km/h"),
    ("value = 60.2", "value = 1e9", "first_hopf_kmh value = 1000000000.0: a speed must be in (0, 1000] km/h"),
    ("value = 60.2", "value = 1000.5", "a speed must be in (0, 1000] km/h"),
])
def test_observed_speeds_outside_what_a_car_drives_are_refused(tmp_path, old, new, message):
    path = tmp_path / "obs.toml"
    path.write_text(OBS_TOML.replace(old, new, 1))
    with pytest.raises(CalibrationError, match=message.replace("(", r"\(").replace("]", r"\]")):
        read_observations(path, Params())
    code, out, err = run_main(["calibrate", "--observed", str(path), "--vary", KEYS[0], "--json"])
    assert code == 2 and out == "" and err.count("\n") == 1


def test_friction_observation_outside_what_rubber_gives_is_refused(tmp_path):
    path = tmp_path / "obs.toml"
    path.write_text('[[observation]]\nquantity = "friction_mu"\nvalue = 5.0\nsigma = 0.1\n'
                    "at_sliding_speed_m_per_s = 0.25\n")
    with pytest.raises(CalibrationError, match=r"friction_mu value = 5.0: must be in \(0, 3\]"):
        read_observations(path, Params())


def test_value_on_its_validation_bound_is_a_warning_not_a_result(tmp_path):
    """mu = 2.9 at v = 0.5 m/s needs mu_s = 0.5 + 2.4 / exp(-4) (about 131) on the default curve:
    the fit stops at the key's bound 3, and says so."""
    obs = [Observation("friction_mu", 2.9, 0.01, at_sliding_speed_m_per_s=0.5)]
    result = calibrate(Params(), obs, ["friction.mu_static"], profile=False)
    entry = result.parameters[0]
    assert entry["value"] == pytest.approx(3.0, rel=1e-6) and entry["at_bound"]
    [warning] = result.identifiability["warnings"]
    assert warning.startswith("friction.mu_static = 3 is at its validation bound 3: the data do not fit")
    fine = calibrate(Params(), [Observation("friction_mu", 0.7, 0.01, at_sliding_speed_m_per_s=0.2)],
                     ["friction.mu_static"], profile=False)
    assert not fine.parameters[0]["at_bound"] and fine.identifiability["warnings"] == []
    path = tmp_path / "obs.toml"
    path.write_text('[[observation]]\nquantity = "friction_mu"\nvalue = 2.9\nsigma = 0.01\n'
                    "at_sliding_speed_m_per_s = 0.5\n")
    code, out, err = run_main(["calibrate", "--observed", str(path), "--vary", "friction.mu_static", "--no-profile"])
    assert code == 0 and "warning: friction.mu_static = 3 is at its validation bound" in err


def test_interrupted_calibrate_leaves_none_of_its_outputs(tmp_path, monkeypatch):
    """Ctrl-C while the figure is drawn (the last output): neither --out nor --fitted is left."""
    from polywear.measured.calibration import CalibrationResult

    def interrupted(self, ax=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(CalibrationResult, "plot", interrupted)
    path = tmp_path / "obs.toml"
    path.write_text(OBS_TOML)
    outputs = [tmp_path / "fit.json", tmp_path / "fitted.toml", tmp_path / "fit.png"]
    code, _, _ = run_main(["calibrate", "--observed", str(path), "--vary", KEYS[0], "--no-profile", "-q",
                           "--out", str(outputs[0]), "--fitted", str(outputs[1]), "--plot", str(outputs[2])])
    assert code == 130
    assert sorted(p.name for p in tmp_path.iterdir()) == ["obs.toml"]


@pytest.mark.parametrize(("text", "message"), [
    ('[[observation]]\nquantity = "friction_mu"\nvalue = 0.7\nsigma = 0.02\nat_sliding_speed_m_per_s = 1e308\n',
     "at_sliding_speed_m_per_s = 1e+308: must be in (0, 1000] m/s"),
    ('[[observation]]\nquantity = "hopf_frequency_hz"\nvalue = 1e308\nsigma = 1e-300\n',
     "the residuals over their sigma overflow"),
    ('[[observation]]\nquantity = "first_hopf_kmh"\nvalue = 58.1\nsigma = 1e-308\n',
     "the residuals over their sigma overflow"),
])
def test_observations_out_of_scale_are_one_line_without_nan(tmp_path, text, message):
    """Found by the fuzz harness: these ended in an OverflowError or Infinity in the JSON."""
    path = tmp_path / "obs.toml"
    path.write_text(text)
    code, out, err = run_main(["calibrate", "--observed", str(path), "--vary", "friction.mu_static", "--no-profile",
                               "--json", "-q"])
    assert code == 2 and out == "" and err.count("\n") == 1 and message in err, err
