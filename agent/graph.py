"""The agent: retrieve -> generate -> execute -> validate, repairing up to the attempt limit,
then ``fallback`` (the reference script run directly) as the terminal node.

    START -> retrieve -> generate -> execute -> validate -> END      (valid)
    generate, repair -> execute, or -> fallback                     (LLM down, if so set)
    execute  -> validate if the script ran, else repair or fallback
    validate -> END if valid, else repair (attempts left) or fallback
    fallback -> END
"""

from __future__ import annotations

from typing import Literal

from langgraph.graph import END, START, StateGraph
from langgraph.runtime import Runtime

from scenweave.agent.context import AgentContext
from scenweave.agent.nodes import execute, fallback, generate, repair, retrieve, validate
from scenweave.agent.state import AgentState


def after_generation(state: AgentState) -> Literal["execute", "fallback"]:
    """The LLM could not be asked (and the settings say fall back): go straight to fallback."""
    return "fallback" if state["attempts"][-1].get("llm_failed") else "execute"


def after_execute(state: AgentState, runtime: Runtime[AgentContext]) -> Literal[
        "validate", "repair", "fallback"]:
    """A script that ran is validated; a failed one is repaired while attempts are left."""
    if state["attempts"][-1].get("error") is None:
        return "validate"
    return _retry_or_fallback(state, runtime.context)


def after_validate(state: AgentState, runtime: Runtime[AgentContext]) -> Literal[
        "repair", "fallback", "__end__"]:
    """Valid: done. Invalid (including a changed number): repair or fall back."""
    if state.get("final"):
        return "__end__"  # langgraph's END, as the literal this router's type names
    return _retry_or_fallback(state, runtime.context)


def _retry_or_fallback(state: AgentState, ctx: AgentContext) -> Literal["repair", "fallback"]:
    return "repair" if len(state["attempts"]) < ctx.settings.max_attempts else "fallback"



def build_graph() -> StateGraph[AgentState, AgentContext, AgentState, AgentState]:
    """The agent's graph, not yet compiled (compile with a checkpointer to run it)."""
    graph = StateGraph(AgentState, context_schema=AgentContext)
    graph.add_node(retrieve)
    graph.add_node(generate)
    graph.add_node(execute)
    graph.add_node(validate)
    graph.add_node(repair)
    graph.add_node(fallback)

    graph.add_edge(START, "retrieve")
    graph.add_edge("retrieve", "generate")
    graph.add_conditional_edges("generate", after_generation)
    graph.add_conditional_edges("repair", after_generation)
    graph.add_conditional_edges("execute", after_execute)
    graph.add_conditional_edges("validate", after_validate)
    graph.add_edge("fallback", END)
    return graph
