"""Urban class codes, their corpus tags (from the corpus's own table) and readable names."""

from __future__ import annotations

from scenweave.corpus.retrieval import CLASS_TAGS

URBAN_TAGS = {code: tag for code, tag in CLASS_TAGS.items() if code.startswith("U")}

URBAN_NAMES = {
    "U1_1": "In-lane driving",
    "U4_1": "Ego stop at traffic light",
    "U4_2": "Ego pass traffic light",
    "U4_3": "Ego straight through green traffic light",
    "U4_4": "Ego right turn at green traffic light",
}
