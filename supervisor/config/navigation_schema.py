"""The scenario's [navigation] section: the sensors a vehicle navigates by and the filter that fuses them.

Absent (the default), every controller sees the true state, as in the paper. Present, each vehicle's controller sees
a Kalman estimate of its position fused from dead reckoning (DVL velocity with noise and a constant bias, AHRS
heading with noise), a depth sensor and periodic horizontal position fixes (USBL/LBL) that may drop out
(vehicles.navigation). Typical numbers: DVL 0.5 % of speed +- 0.5 cm/s; compass/AHRS 0.5-2 deg; depth 0.01-0.1 % of
full scale; USBL 0.1-1 % of slant range, every few seconds.
"""

from __future__ import annotations

from pydantic import Field

from supervisor.config.schema_base import MAX_LENGTH, MAX_TIME, Float, Probability, StrictModel


class NavigationSection(StrictModel):
    """Each vehicle's controller runs on an estimate of its position, not the truth; standard deviations (1 sigma)."""

    dvl_noise: Float = Field(default=0.005, ge=0, le=1.0, description="DVL velocity white noise per body axis, m/s")
    dvl_bias: Float = Field(
        default=0.002, ge=0, le=1.0,
        description="spread of the DVL's constant bias per body axis, m/s (one draw per vehicle; the filter "
        "estimates it)",
    )  # fmt: skip
    heading_noise_deg: Float = Field(default=1.0, ge=0, le=45.0, description="AHRS heading white noise, deg")
    depth_noise: Float = Field(default=0.05, ge=0, le=100.0, description="depth sensor white noise, m")
    fix_period: Float = Field(
        default=10.0, gt=0, le=MAX_TIME, description="time between position fixes (USBL/LBL), s; rounded up to steps"
    )
    fix_noise: Float = Field(default=1.0, gt=0, le=MAX_LENGTH, description="position fix noise per horizontal axis, m")
    fix_dropout: Probability = Field(default=0.0, description="probability a fix is lost")
    initial_error: Float = Field(
        default=1.0, ge=0, le=MAX_LENGTH, description="spread of the initial position estimate per axis, m"
    )
