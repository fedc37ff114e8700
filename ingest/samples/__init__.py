"""Seeded, realistic sample data in exactly the MOOVE formats (the real data is confidential)."""

from scenweave.ingest.samples.highway import write_highway_samples
from scenweave.ingest.samples.urban import write_urban_samples

__all__ = ["write_highway_samples", "write_urban_samples"]
