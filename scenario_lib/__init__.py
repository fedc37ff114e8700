"""The scenario library: what the reference scripts and the LLM-written scripts import.

``builder`` (actors, events, speed profiles, lights, ``make_scenario``, ``write_scenario``),
``kinematics`` (the timing rules) and ``phases`` (speed profiles as phases). The sandbox mounts
this folder alone, read-only, as ``scenweave.scenario_lib``: it imports nothing of ScenWeave's
but itself (standard library and scenariogeneration), and this file imports nothing at all.
Scenario layout: ``docs/scenario-conventions.md``.
"""
