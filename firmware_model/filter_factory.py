"""The yaw filter implementation by name: ``"float"`` (:class:`firmware_model.yaw_filter.FloatYawFilter`) or
``"fixed"`` (:class:`firmware_model.fixed_filter.FixedYawFilter`, the MCU's fixed-point arithmetic).

Both implement :class:`firmware_model.yaw_filter.YawFilter`; the factory sits above the two so that neither
imports the other's module (the fixed filter builds on the float filter's interface).
"""

from __future__ import annotations

from firmware_model.errors import FirmwareError
from firmware_model.fixed_filter import FixedFormats, FixedYawFilter
from firmware_model.yaw_filter import FloatYawFilter, YawFilter, YawFilterConfig

IMPLEMENTATIONS = ("float", "fixed")


def make_yaw_filter(kind: str, config: YawFilterConfig, realizations: int, initial_yaw_rad=0.0,
                    bias_offset_rad_s=0.0, formats: FixedFormats | None = None) -> YawFilter:
    """The filter implementation named ``kind`` ("float" or "fixed"; ``formats`` only for "fixed")."""
    if kind == "float":
        if formats is not None:
            raise FirmwareError("formats: only the 'fixed' implementation takes fixed-point formats")
        return FloatYawFilter(config, realizations, initial_yaw_rad, bias_offset_rad_s)
    if kind == "fixed":
        return FixedYawFilter(config, realizations, initial_yaw_rad, bias_offset_rad_s, formats=formats)
    raise FirmwareError(f"filter implementation = {kind!r}: allowed {list(IMPLEMENTATIONS)}")
