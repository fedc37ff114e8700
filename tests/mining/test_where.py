"""The ``--where`` language (issue 32 item 5): what it matches, and the column it names when
it cannot be read."""

from __future__ import annotations

import pytest

from scenweave.mining.where import WhereError, known_fields, parse_where, tokenize

CUT_IN = {"maneuver_class": "CINF", "domain": "highway", "has_npc": True,
          "scenario_id": "CINF_mined_x_row000001",
          "provenance": {"file": "/data/us101/USA_US101-9_1_T-1.xml", "tracks": {"ego": "400",
                                                                                 "npc": "402"},
                         "start_s": 1.0, "end_s": 4.5},
          "params": {"ego_vel_kmh": 52.7, "direction": "Left"},
          "criticality": {"ttc_min_s": 1.4, "thw_min_s": 0.6, "brake_1s_max_ms2": 2.1,
                          "lat_acc_peak_ms2": 0.9}}
FREE_RIDE = {"maneuver_class": "FRF", "domain": "highway", "has_npc": False,
             "criticality": {"ttc_min_s": None, "thw_min_s": None, "brake_1s_max_ms2": 0.4,
                             "lat_acc_peak_ms2": 0.3}}


def matches(text: str) -> list[str]:
    test = parse_where(text)
    return [r["maneuver_class"] for r in (CUT_IN, FREE_RIDE) if test(r)]


@pytest.mark.parametrize("text, wanted", [
    ("ttc_min_s < 2 and maneuver_class in (CINF, CINB)", ["CINF"]),
    ("ttc_min_s >= 2", []),
    ("not ttc_min_s < 2", ["FRF"]),  # the free ride has none: its comparison is false
    ("ttc_min_s not in (1.4)", []),
    ("maneuver_class not in (CINF)", ["FRF"]),
    ("brake_1s_max_ms2 > 2 or maneuver_class == FRF", ["CINF", "FRF"]),
    ("(thw_min_s <= 0.6 or lat_acc_peak_ms2 > 5) AND domain == 'highway'", ["CINF"]),
    ('file == "USA_US101-9_1_T-1.xml" and ego == 400 and npc != 401', ["CINF"]),
    ("has_npc == false", ["FRF"]),
    ("duration_s > 3 and start_s == 1", ["CINF"]),
    ("ego_vel_kmh > 50 and direction == Left", ["CINF"]),
    ("maneuver_class < 2", []),  # text against a number: false, not an error
    ("brake_1s_max_ms2>=.4", ["CINF", "FRF"]),
])
def test_what_an_expression_matches(text, wanted):
    assert matches(text) == wanted


@pytest.mark.parametrize("text, column, expected", [
    ("ttc_min_s <", 12, "expected a value"),
    ("ttc_min_s < 2 and", 18, "expected a field name"),
    ("(ttc_min_s < 2", 15, "expected ')'"),
    ("ttc_min_s = 2", 11, "unexpected character '='"),
    ("ttc_min_s in CINF", 14, "expected '(' opening the list"),
    ("maneuver_class in (CINF,)", 25, "expected a value"),
    ("ttc_min_s < 2 maneuver_class", 15, "expected 'and', 'or' or the end"),
    ("ttc_min_s not < 2", 15, "expected 'in'"),
    ("", 1, "expected a comparison"),
    ("ttc_min_s < 'open", 13, "unexpected character"),
])
def test_a_malformed_expression_names_its_column(text, column, expected):
    with pytest.raises(WhereError) as caught:
        parse_where(text)
    message = str(caught.value)
    assert message.startswith(f"column {column}: ") and expected in message
    assert "\n" not in message


def test_an_unknown_field_lists_the_known_ones():
    with pytest.raises(WhereError, match=r"column 18: unknown field 'ttc'; known: ttc_min_s, "):
        parse_where("ttc_min_s < 2 or ttc < 2")
    assert {"ttc_min_s", "maneuver_class", "ego_vel_kmh"} <= set(known_fields())


def test_user_text_is_only_tokens_never_python():
    with pytest.raises(WhereError, match="column 17: unexpected character '.'"):
        parse_where("__import__('os').system('true')")
    assert [t.kind for t in tokenize("a <= -1.5e2 'x y'")] == ["word", "op", "number", "string",
                                                                "end"]


def test_a_record_mined_before_criticality_is_measured_from_its_series():
    old = {"maneuver_class": "FLF", "series": {
        "t": [0.0, 0.5, 1.0], "ego_speed_raw_ms": [20.0] * 3, "npc_speed_raw_ms": [10.0] * 3,
        "npc_gap_m": [30.0, 25.0, 20.0], "ego_lane": [1.0] * 3, "npc_lane": [1.0] * 3}}
    assert parse_where("ttc_min_s == 2")(old)


def test_the_parser_never_evaluates_python():
    """The module reads user text with its own tokenizer: no eval, exec, compile or
    literal_eval is called anywhere in it."""
    import ast
    from pathlib import Path

    from scenweave.mining import where

    tree = ast.parse(Path(where.__file__).read_text(encoding="utf-8"))
    called = {node.func.id if isinstance(node.func, ast.Name) else ast.unparse(node.func)
              for node in ast.walk(tree) if isinstance(node, ast.Call)}
    assert called.isdisjoint({"eval", "exec", "compile", "ast.literal_eval", "__import__"})
    assert {name for name in called if name.endswith("compile")} == {"re.compile"}
    assert "tokenize" in called  # the check looks at real calls
