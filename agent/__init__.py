"""The agent: a LangGraph StateGraph that retrieves a reference script, has a local LLM adapt
it to a record's params, runs the result in a sandbox, validates it, repairs it, and falls
back to the reference script when attempts run out. See ``agent/graph.py``.

``run_scenario(params, out_dir, AgentSettings(...))`` -> :class:`AgentOutcome`.
"""

from agent.llm.base import LLMTimeout, LLMUnavailable
from agent.run import AgentOutcome, close_shared, run_scenario
from agent.settings import LLM_CHOICES, AgentSettings

__all__ = ["LLM_CHOICES", "AgentOutcome", "AgentSettings", "LLMTimeout", "LLMUnavailable",
           "close_shared", "run_scenario"]
