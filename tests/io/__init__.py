"""Tests of layer 4, pinclear.io."""
