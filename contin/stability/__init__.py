"""Stability of periodic solutions."""
