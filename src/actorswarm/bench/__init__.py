"""Benchmarks that measure the framework against docs/design.md §8."""
