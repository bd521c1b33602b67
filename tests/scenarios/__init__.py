"""Data-driven scenario files of the collective core (see README.md)."""
