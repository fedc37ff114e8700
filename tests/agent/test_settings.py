"""AgentSettings refuses what no run could use, naming the option and the choices."""

from __future__ import annotations

import pytest

from scenweave.agent import AgentSettings
from scenweave.agent.repair import strategy_names


@pytest.mark.parametrize("given, kept", [("patch", "patch"),
                                         ("error-feedback", "error_feedback"),
                                         ("code_corrections", "code_corrections")])
def test_repair_names_are_normalised(given, kept):
    assert AgentSettings(llm="replay", repair=given).repair == kept


def test_an_unknown_repair_strategy_is_refused_with_the_choices():
    with pytest.raises(ValueError, match=r"--repair 'typo'") as raised:
        AgentSettings(llm="replay", repair="typo")
    for name in strategy_names():
        assert name.replace("_", "-") in str(raised.value)
