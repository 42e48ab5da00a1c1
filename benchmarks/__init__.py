"""Benchmarks of taptune: scripts that print figures, not tests (``python -m benchmarks.<name>``)."""
