"""Validation truth generators for the gap diagnosis (imported only by tests and benchmarks)."""
