"""Tests of layer 8, pinclear.studies."""
