"""Shared fixtures: the OpenSCENARIO 1.0 XSD (loaded once) and a scenario reader."""

from __future__ import annotations

from importlib.resources import files

import pytest
from lxml import etree


@pytest.fixture(scope="session")
def xsd_1_0() -> etree.XMLSchema:
    """The OpenSCENARIO 1.0 schema bundled in asam-qc-openscenarioxml."""
    path = files("qc_openscenario") / "schema" / "1.0.0" / "OpenSCENARIO.xsd"
    return etree.XMLSchema(etree.parse(str(path)))
