"""Tests of layer 2, pinclear.contact."""
