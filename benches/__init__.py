"""Test benches and case generators (not part of the installed library).

Importable from the repository root (tests and scripts put it on ``sys.path``); nothing
in :mod:`vfmodel` imports from here.
"""
