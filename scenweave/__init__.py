"""ScenWeave: real driving records in, validated OpenSCENARIO 1.0 scenarios for CARLA out."""

__version__ = "0.1.0"
