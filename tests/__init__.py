"""pinclear's tests: one folder per layer of the package (docs/design.md, "Layers"); shared
helpers in tests/helpers.py, fixtures in tests/conftest.py."""
