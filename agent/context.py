"""What the nodes use but the state does not store: settings, the LLM, sandbox and trace."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from scenweave.agent.settings import AgentSettings

if TYPE_CHECKING:
    from scenweave.agent.llm.base import LLM
    from scenweave.agent.repair.base import RepairStrategy
    from scenweave.agent.trace import Trace
    from scenweave.sandbox import Sandbox


@dataclass
class AgentContext:
    """The runtime of one graph run (LangGraph ``context_schema``)."""

    settings: AgentSettings
    llm: LLM
    sandbox: Sandbox
    strategy: RepairStrategy
    trace: Trace
