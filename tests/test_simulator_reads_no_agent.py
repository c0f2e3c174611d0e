"""The simulator reads no agent setting (issue 53, item 3; docs/architecture.md): what an
agent sees of the network (the users' order, every UAV's local part, scaled or raw values) is
the adapter it picks in ``adaptsky.envs.observations``, handed to the simulator. No module of
``adaptsky/sim/`` reads ``<something>.agent`` in its code (docstrings and comments aside)."""

from __future__ import annotations

import ast
from pathlib import Path

SIM = Path(__file__).resolve().parent.parent / "adaptsky" / "sim"


def _reads_agent(node: ast.AST) -> bool:
    """Whether ``node`` reads an attribute named ``agent`` (``scenario.agent``,
    ``getattr(x, "agent")``) or imports the agents' settings."""
    if isinstance(node, ast.Attribute):
        return node.attr == "agent"
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        return (node.func.id == "getattr" and len(node.args) > 1
                and isinstance(node.args[1], ast.Constant) and node.args[1].value == "agent")
    return isinstance(node, ast.ImportFrom) and (node.module or "").endswith("agents")


def agent_reads(source: str) -> list[int]:
    """The lines of ``source`` that read an agent setting (:func:`_reads_agent`)."""
    return sorted(node.lineno for node in ast.walk(ast.parse(source)) if _reads_agent(node))


def test_the_check_finds_each_way_of_reading_an_agent_setting():
    source = ("from adaptsky.scenario.agents import DqnAgent\n"
              "x = scenario.agent.user_order\n"
              "y = getattr(scenario, 'agent')\n"
              "z = scenario.agents_count  # not the agent\n")
    assert agent_reads(source) == [1, 2, 3]


def test_no_simulator_module_reads_an_agent_setting():
    found = [f"{path.name}:{line}" for path in sorted(SIM.glob("*.py"))
             for line in agent_reads(path.read_text())]
    assert found == [], f"the simulator reads agent settings at {found}"
