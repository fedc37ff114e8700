"""What every stage takes: the one rule that decides whether a canonical record becomes a
scenario. ``ingest``, ``mine`` and ``run`` all ask :func:`admit`, so whatever ``ingest``
writes, ``run`` makes a scenario of.

A record is admitted when it meets its JSON Schema, its params meet the contract
(``schemas.params``: a field no stage needs is optional there) and a replay can show them
(``check_playable``). Anything else is one :class:`RecordIssue` naming the field.
"""

from __future__ import annotations

from scenweave.ingest.extract import extract_params
from scenweave.ingest.issues import RecordIssue
from scenweave.ingest.playable import check_playable
from scenweave.ingest.records import check_record
from scenweave.schemas.params import Params


def admit(record: dict) -> Params:
    """The params of ``record``, or :class:`RecordIssue` naming why no scenario can show it."""
    check_record(record)
    try:
        params = extract_params(record)
    except KeyError as err:
        raise RecordIssue(f"cannot extract params: {err.args[0]!r} is missing",
                          field=str(err.args[0])) from err
    except (TypeError, ValueError) as err:
        raise RecordIssue(f"cannot extract params: {err}") from err
    check_playable(params)
    return params
