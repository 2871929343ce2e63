"""Tests of layer 7, pinclear.viz."""
