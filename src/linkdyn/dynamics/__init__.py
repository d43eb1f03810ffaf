"""Inverse dynamics: the recursive DeNOC solver (:mod:`.denoc`) and the slow explicit-matrix
reference used by the tests (:mod:`.dense`)."""

from .denoc import DynamicSolution, newton_euler, solve

__all__ = ["DynamicSolution", "newton_euler", "solve"]
