"""Tests of layer 9, pinclear.cli."""
