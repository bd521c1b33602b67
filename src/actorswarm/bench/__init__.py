"""Benchmarks that measure the framework against DESIGN.md §8."""
