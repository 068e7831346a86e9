"""Fuzzing the scenario language: every line, however broken, is reported or run, never ends or hangs a run.

``python -m tests.fuzz --lines 1000000`` runs the long version (docs/reliability.md has its figures);
``tests/test_fuzz.py`` runs a short one in the test suite.
"""
