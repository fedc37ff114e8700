"""Stand-ins for the services ScenWeave talks to, for its tests and benchmarks: a loopback
HTTP server speaking Ollama's API (``fake_ollama``) and a throwaway ``redis-server``
(``redis_server``).

They live in the installed package, not under ``tests/``, so the tests and
``benchmarks/*.py`` import them the same way and no benchmark depends on the test suite.
Standard library only; nothing in the application imports this package.
"""
