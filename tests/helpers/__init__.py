"""Test-only helpers (synthetic scenes and renderers); not part of the product."""
