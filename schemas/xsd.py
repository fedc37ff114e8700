"""The OpenSCENARIO 1.0 XSD, as bundled in the PyPI package ``asam-qc-openscenarioxml``."""

from __future__ import annotations

from functools import cache
from importlib.resources import files
from pathlib import Path

from lxml import etree

from scenweave.errors import InfrastructureError


class SchemaUnavailable(InfrastructureError, RuntimeError):
    """The XSD cannot be found: the package ``asam-qc-openscenarioxml`` is missing."""


def xsd_path() -> Path:
    """Where the OpenSCENARIO 1.0 schema file lives."""
    try:
        path = Path(str(files("qc_openscenario") / "schema" / "1.0.0" / "OpenSCENARIO.xsd"))
    except ModuleNotFoundError as err:
        raise SchemaUnavailable("OpenSCENARIO 1.0 XSD not found: install the PyPI package "
                                "asam-qc-openscenarioxml (bash scripts/setup.sh does)") from err
    if not path.is_file():
        raise SchemaUnavailable(f"OpenSCENARIO 1.0 XSD missing at {path}: reinstall "
                                "asam-qc-openscenarioxml")
    return path


@cache
def osc_1_0_schema() -> etree.XMLSchema:
    """The parsed schema, loaded once per process."""
    return etree.XMLSchema(etree.parse(str(xsd_path())))

