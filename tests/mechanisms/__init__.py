"""Tests of layer 5, pinclear.mechanisms."""
