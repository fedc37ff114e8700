"""The OpenSCENARIO 1.0 XSD, as bundled in the PyPI package ``asam-qc-openscenarioxml``."""

from __future__ import annotations

from functools import cache
from importlib.util import find_spec
from pathlib import Path

from lxml import etree

from scenweave.errors import InfrastructureError


class SchemaUnavailable(InfrastructureError, RuntimeError):
    """The XSD cannot be found: the package ``asam-qc-openscenarioxml`` is missing."""


def xsd_path() -> Path:
    """Where the OpenSCENARIO 1.0 schema file lives: found without importing the package
    (``importlib.resources.files`` runs its ``__init__``, which imports every ASAM check:
    0.4 s of CPU before a run's first scenario)."""
    spec = find_spec("qc_openscenario")
    if spec is None or not spec.submodule_search_locations:
        raise SchemaUnavailable("OpenSCENARIO 1.0 XSD not found: install the PyPI package "
                                "asam-qc-openscenarioxml (bash scripts/setup.sh does)")
    package = Path(next(iter(spec.submodule_search_locations)))
    path = package / "schema" / "1.0.0" / "OpenSCENARIO.xsd"
    if not path.is_file():
        raise SchemaUnavailable(f"OpenSCENARIO 1.0 XSD missing at {path}: reinstall "
                                "asam-qc-openscenarioxml")
    return path


@cache
def osc_1_0_schema() -> etree.XMLSchema:
    """The parsed schema, loaded once per process."""
    return etree.XMLSchema(etree.parse(str(xsd_path())))

