"""Motion laws: shapes and closed-form values."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from batchveh.config import ConfigError
from batchveh.model import laws


def test_ramp_saturates_and_seed_ramp_does_not():
    t = jnp.array([0.0, 1.5, 3.0, 6.0])
    np.testing.assert_allclose(laws.ramp(t, 0.0, 2.0, 3.0), [0, 1, 2, 2])
    np.testing.assert_allclose(laws.unbounded_ramp(t, 0.0, 2.0, 3.0), [0, 1, 2, 4])


def test_smooth_step_has_zero_rate_at_both_ends():
    rate = jax.grad(lambda t: laws.smooth_step(t, 0.0, 1.0, 2.0, 1.0))
    assert float(rate(1.0)) == pytest.approx(0.0, abs=1e-6)
    assert float(rate(3.0)) == pytest.approx(0.0, abs=1e-6)
    assert float(laws.smooth_step(2.0, 0.0, 1.0, 2.0, 1.0)) == pytest.approx(0.5)
    assert float(rate(2.0)) == pytest.approx(15 / 8 / 2.0)  # peak of the quintic, per second


def test_sine_table_constant():
    assert float(laws.sine(0.25, 1.0, 2.0, 1.0)) == pytest.approx(3.0)
    np.testing.assert_allclose(
        laws.table(jnp.array([-1.0, 0.5, 1.5, 9.0]), (0.0, 1.0, 2.0), (0.0, 2.0, 0.0)), [0, 1, 1, 0]
    )
    assert float(laws.constant(7.0, 3.0)) == 3.0


def test_laws_vmap_over_parameters():
    stops = jnp.array([1.0, 2.0, 3.0])
    out = jax.vmap(lambda s: laws.ramp(10.0, 0.0, s, 3.0))(stops)
    np.testing.assert_allclose(out, stops)


def test_bad_law_specs_name_the_problem():
    with pytest.raises(ConfigError, match="allowed: constant, ramp"):
        laws.law_from_mapping({"law": "jerk"}, "s.yaml: laws.drive")
    with pytest.raises(ConfigError, match="needs 'duration'"):
        laws.law_from_mapping({"law": "ramp", "start": 0, "stop": 1}, "s.yaml: laws.drive")
    with pytest.raises(ConfigError, match="must increase"):
        laws.law_from_mapping({"law": "table", "times": [0, 0], "values": [1, 2]}, "x")
