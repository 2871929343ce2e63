"""Tests of layer 0, pinclear.core."""
