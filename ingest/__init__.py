"""Ingest: raw MOOVE data -> canonical records -> flat params (docs/params.md).

Public API: ``admit`` (the one rule of what becomes a scenario: ingest, mine and run ask it),
``ingest_directory``, ``iter_raw_records``, ``load_records``, ``extract_params``,
``extract_with_variants``, ``check_playable`` (params no replay can show are an input issue),
``load_layouts``, sample data in ``ingest.samples``.
"""

from scenweave.ingest.admission import admit
from scenweave.ingest.batch import ingest_directory, iter_raw_records
from scenweave.ingest.extract import extract_params
from scenweave.ingest.issues import IngestError, IngestReport, Issue, LayoutError
from scenweave.ingest.layouts import load_layouts
from scenweave.ingest.playable import check_playable
from scenweave.ingest.records import check_record, load_records
from scenweave.ingest.variants import extract_with_variants

__all__ = [
    "IngestError", "IngestReport", "Issue", "LayoutError", "admit", "check_playable",
    "check_record",
    "extract_params",
    "extract_with_variants", "ingest_directory", "iter_raw_records", "load_layouts",
    "load_records",
]
