"""Tests of layer 1, pinclear.model."""
