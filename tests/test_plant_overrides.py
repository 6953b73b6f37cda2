"""Per-run plant overrides: the registry, validation, and that each really changes the plant."""
from __future__ import annotations

import json
import math

import pytest

from wheelleg.emulators.plant import OVERRIDES, PlantConfig

REQUIRED = ("body_mass_scale", "com_x_m", "com_z_m", "inertia_scale", "friction", "wheel_radius_scale",
            "hip_kt_scale", "wheel_kt_scale", "hip_damping", "hip_frictionloss", "imu_tilt_pitch_deg",
            "imu_tilt_roll_deg", "imu_gyro_bias", "imu_gyro_bias_x", "imu_gyro_bias_y", "imu_gyro_bias_z",
            "imu_noise_scale", "feedback_delay_s", "command_delay_s", "supply_voltage_v")


def test_registry_has_every_required_key_with_a_sane_spec():
    assert set(REQUIRED) <= set(OVERRIDES)
    for key, spec in OVERRIDES.items():
        assert spec.low <= spec.default <= spec.high, key
        assert spec.description and "\n" not in spec.description, key


def test_from_overrides_takes_strings_and_numbers():
    config = PlantConfig.from_overrides({"com_x_m": "0.02", "friction": 0.4, "supply_voltage_v": "24"})
    assert config.value("com_x_m") == 0.02 and config.value("friction") == 0.4
    assert config.value("hip_damping") == 0.0  # untouched: the default
    assert config.overrides_dict() == {"com_x_m": 0.02, "friction": 0.4}  # 24 V is the default
    assert json.loads(json.dumps(config.overrides_dict())) == config.overrides_dict()
    assert PlantConfig().overrides_dict() == {}


@pytest.mark.parametrize("mapping, words", [
    ({"com_y_m": 0.01}, ["unknown plant override 'com_y_m'", "com_x_m", "supply_voltage_v"]),
    ({"com_x_m": 0.5}, ["com_x_m", "impossible", "-0.1..0.1 m"]),
    ({"friction": "abc"}, ["friction", "not a number"]),
    ({"friction": math.nan}, ["friction", "impossible"]),
    ({"supply_voltage_v": 48}, ["supply_voltage_v", "16..28 V"]),
    ({"feedback_delay_s": -0.001}, ["feedback_delay_s", "impossible"]),
])
def test_a_bad_override_is_a_one_line_error(mapping, words):
    with pytest.raises(ValueError) as info:
        PlantConfig.from_overrides(mapping)
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message


def test_a_config_built_directly_is_checked_too():
    with pytest.raises(ValueError, match="impossible"):
        PlantConfig(overrides={"body_mass_scale": 0.0})
