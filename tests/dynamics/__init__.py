"""Tests of layer 3, pinclear.dynamics."""
