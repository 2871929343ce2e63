"""Tests of layer 6, pinclear.analysis."""
