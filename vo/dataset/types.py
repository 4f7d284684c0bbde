# compat re-export: removed at merge (the records live in rigs.records; ImuData/WheelData are its ImuSamples/WheelSamples)
from rigs.records import Gcp, ImuSamples, StereoFrame, WheelSamples  # noqa: F401

ImuData = ImuSamples
WheelData = WheelSamples
__all__ = ["Gcp", "ImuData", "ImuSamples", "StereoFrame", "WheelData", "WheelSamples"]
